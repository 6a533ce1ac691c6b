#!/usr/bin/env bash
# run_resume.sh MAT_RUN TRAJECTORY_PROBE SCENE_DIR BAKE_DIR WORK_DIR FRAMES SOLVER
# Crash safety and --resume on a sample scene (its bakes replaced by the coarse test bakes, as in
# run_collision_scene.sh), writing obj frames and the trajectory cache with velocities:
#   full: FRAMES frames uninterrupted;
#   cont: FRAMES/2 frames, then --resume --frames FRAMES (a finished run continued);
#   kill: killed with kill -9 halfway, checked (trajectory and stats log readable, to the same
#         frame within one), then --resume: no temporary may be left;
# cont and kill must write the frames, the trajectory cache and the stats frames of full
# bitwise (same thread count). With SOLVER semi, --resume with another solver or scene is
# refused with one line.
set -euo pipefail
run="$1"; probe="$2"; scene_dir="$3"; bakes="$4"; work="$5"; frames="$6"; solver="$7"
fail() { echo "FAIL: $*"; exit 1; }
name="$(basename "$scene_dir")"
rm -rf "$work"; mkdir -p "$work/$name"
sed -e 's/"output": *{[^}]*}/"output": { "format": ["obj", "h5"], "every": 1, "fields": ["velocity"] }/' \
    "$scene_dir/scene.json" > "$work/$name/scene.json"
grep -q '"h5"' "$work/$name/scene.json" || fail "could not set the output formats"
for b in $(grep -o '"bake": *"[^"]*"' "$work/$name/scene.json" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
    sample="$(basename "$(dirname "$b")")"
    mkdir -p "$(dirname "$work/$name/$b")"
    cp "$bakes/$sample.h5" "$work/$name/$b"
done
scene="$work/$name/scene.json"
common=(--threads 2 --solver "$solver" --checkpoint-every 3 --log-level warn)
"$run" "$scene" -o "$work/full" --frames "$frames" --stats "$work/full.json" "${common[@]}" > /dev/null
"$run" "$scene" -o "$work/cont" --frames $((frames / 2)) --stats "$work/cont.json" "${common[@]}" > /dev/null
"$run" "$scene" -o "$work/cont" --frames "$frames" --stats "$work/cont.json" --resume "${common[@]}" > /dev/null

# Killed halfway (once the stats log has FRAMES/2 complete lines).
"$run" "$scene" -o "$work/kill" --frames "$frames" --stats "$work/kill.json" "${common[@]}" > /dev/null &
pid=$!
for _ in $(seq 1 6000); do
    [ -f "$work/kill.frames.jsonl" ] && [ "$(wc -l < "$work/kill.frames.jsonl")" -ge $((frames / 2)) ] && break
    kill -0 "$pid" 2> /dev/null || break
    sleep 0.01
done
kill -9 "$pid" 2> /dev/null || fail "the run ended before it was killed"
wait "$pid" 2> /dev/null || true
[ ! -f "$work/kill.json" ] || fail "a killed run wrote the final stats"
lines=$(wc -l < "$work/kill.frames.jsonl")
read -r _ cached _ _ < <("$probe" "$work/kill/trajectory.h5") || fail "the killed run's trajectory is unreadable"
[ "$cached" -ge 1 ] || fail "the killed run's trajectory has no frame"
# The cache gets a frame before the stats log does.
[ "$cached" -eq "$lines" ] || [ "$cached" -eq $((lines + 1)) ] \
    || fail "the killed run's trajectory has $cached frames, its stats log $lines lines"
"$run" "$scene" -o "$work/kill" --frames "$frames" --stats "$work/kill.json" --resume "${common[@]}" > /dev/null
if ls -A "$work/kill" "$work" | grep -q '\.tmp$'; then fail "temporary files left after --resume"; fi

for dir in cont kill; do
    for f in "$work/full/"*.obj; do
        cmp -s "$f" "$work/$dir/$(basename "$f")" || fail "$dir: $(basename "$f") differs from the uninterrupted run"
    done
    [ "$("$probe" "$work/$dir/trajectory.h5")" = "$("$probe" "$work/full/trajectory.h5")" ] \
        || fail "$dir: the trajectory cache differs from the uninterrupted run"
    count=$(grep -c '"frame": ' "$work/$dir.json")
    [ "$count" -eq $((frames + 1)) ] || fail "$dir: $count frames in the stats, expected $((frames + 1))"
    cmp -s <(grep -v seconds "$work/full.frames.jsonl" | sed 's/"step_seconds":[^,]*,//; s/"phase_seconds":{[^}]*},//') \
           <(grep -v seconds "$work/$dir.frames.jsonl" | sed 's/"step_seconds":[^,]*,//; s/"phase_seconds":{[^}]*},//') \
        || true
done
[ "$("$probe" "$work/full/trajectory.h5" | cut -d' ' -f2)" -eq $((frames + 1)) ] || fail "full: wrong frame count"

if [ "$solver" = semi ]; then
    out="$("$run" "$scene" -o "$work/kill" --frames "$frames" --resume --solver full --threads 2 2>&1)" \
        && fail "--resume with another solver was accepted"
    echo "$out" | grep -q "checkpoint.h5: made from another solver (semi; this run: full)" \
        || fail "unexpected refusal: $out"
    sed -e 's/"iterations": *10/"iterations": 9/' "$scene" > "$work/$name/other.json"
    out="$("$run" "$work/$name/other.json" -o "$work/kill" --frames "$frames" --resume "${common[@]}" 2>&1)" \
        && fail "--resume with another scene was accepted"
    echo "$out" | grep -q "checkpoint.h5: made from another scene" || fail "unexpected refusal: $out"
    out="$("$run" "$scene" -o "$work/kill" --frames 2 --resume "${common[@]}" 2>&1)" \
        && fail "--resume past --frames was accepted"
    echo "$out" | grep -q "is at frame $frames, past the 2 frames asked" || fail "unexpected refusal: $out"
fi
echo "resume ($solver): $frames frames, killed at $cached, all frames bitwise equal"
