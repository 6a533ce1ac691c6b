#!/usr/bin/env bash
# kill_resume.sh BUILD_DIR WORK_DIR [KILLS] [FRAMES] [SCENE]: crash safety and --resume under
# kill -9 (docs/mat-run.md, "Killed runs, checkpoints and --resume"). Runs SCENE (default
# samples/capsule/scene.json, obj + h5 output with velocities, --stats) for FRAMES frames
# (default 2000) uninterrupted, then again in another folder, killed with kill -9 at KILLS
# (default 20) random frames (fixed seed; each kill once the stats log has reached that frame)
# and resumed with --resume after each kill. After every kill: the trajectory cache and the stats
# log must be readable to the last complete frame (the cache at most one frame ahead of the log),
# that frame of the cache must equal the uninterrupted run's bitwise, and the temporaries the
# killed run left must be gone once the next run has started. At the end every frame file, the
# trajectory cache's last frame and the stats' frames must equal the uninterrupted run's.
# Needs the sample bakes (make -C samples) and BUILD_DIR/tests/cli/trajectory_probe.
set -uo pipefail
build="$1"; work="$2"; kills="${3:-20}"; frames="${4:-2000}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
source_scene="${5:-$root/samples/capsule/scene.json}"
run="$build/runtime/mat-run"; probe="$build/tests/cli/trajectory_probe"
fail() { echo "kill_resume: FAIL: $*"; exit 1; }
rm -rf "$work"; mkdir -p "$work"
# The scene with obj and h5 output, beside links to its bakes.
mkdir -p "$work/scene"
scene="$work/scene/scene.json"
sed -e 's/"output": *{[^}]*}/"output": { "format": ["obj", "h5"], "every": 1, "fields": ["velocity"] }/' \
    "$source_scene" > "$scene"
for b in $(grep -o '"bake": *"[^"]*"' "$scene" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
    mkdir -p "$(dirname "$work/scene/$b")"
    ln -s "$(cd "$(dirname "$source_scene")" && realpath "$b")" "$work/scene/$b"
done
common=(--frames "$frames" --threads 2 --log-level info --progress-every 30)
start=$SECONDS
"$run" "$scene" -o "$work/ref" --stats "$work/ref.json" "${common[@]}" > "$work/ref.log" 2>&1 \
    || fail "the uninterrupted run failed (see $work/ref.log)"
echo "uninterrupted: $frames frames in $((SECONDS - start)) s"

# KILLS distinct random frames in 1 .. FRAMES-1, increasing.
points=$(python3 -c "import random; random.seed(7); print(*sorted(random.sample(range(1, $frames), $kills)))")
log="$work/kill.frames.jsonl"
previous_tmp=""
resume=()
n=0
for point in $points; do
    n=$((n + 1))
    "$run" "$scene" -o "$work/kill" --stats "$work/kill.json" "${common[@]}" "${resume[@]}" \
        >> "$work/kill.log" 2>&1 &
    pid=$!
    until [ -f "$log" ] && [ "$(wc -l < "$log")" -gt "$point" ]; do
        kill -0 "$pid" 2> /dev/null || fail "run $n ended before frame $point"
        sleep 0.02
    done
    # The temporaries of the run killed before must be gone now that this one has started.
    for f in $previous_tmp; do [ -e "$f" ] && fail "run $n: $f of the killed run is still there"; done
    kill -9 "$pid"; wait "$pid" 2> /dev/null
    resume=(--resume)
    read -r _ cached _ hash < <("$probe" "$work/kill/trajectory.h5") || fail "kill $n: trajectory.h5 unreadable"
    lines=$(python3 - "$log" <<'PY'
import json, sys
text = open(sys.argv[1]).read()
complete = text.split('\n')[:-1]  # a last line without its newline is incomplete
for i, line in enumerate(complete):
    assert json.loads(line)['frame'] == i, 'frame %d out of order' % i
print(len(complete))
PY
) || fail "kill $n: the stats log is not valid JSON Lines"
    { [ "$cached" -eq "$lines" ] || [ "$cached" -eq $((lines + 1)) ]; } \
        || fail "kill $n: trajectory has $cached frames, the stats log $lines"
    [ "$hash" = "$("$probe" "$work/ref/trajectory.h5" $((cached - 1)) | cut -d' ' -f4)" ] \
        || fail "kill $n: frame $((cached - 1)) of the trajectory differs from the uninterrupted run"
    previous_tmp=$(ls -A "$work/kill" "$work" 2> /dev/null | grep '\.tmp$' | while read -r t; do
        [ -e "$work/kill/$t" ] && echo "$work/kill/$t" || echo "$work/$t"; done)
    checkpoint=$(( (cached - 1) / 10 * 10 ))
    echo "kill $n at frame $point: trajectory $cached frames, stats log $lines frames (last frame bitwise equal), $(echo $previous_tmp | wc -w) temporaries left, resumes after frame $checkpoint"
done
"$run" "$scene" -o "$work/kill" --stats "$work/kill.json" "${common[@]}" --resume >> "$work/kill.log" 2>&1 \
    || fail "the last --resume failed (see $work/kill.log)"
for f in $previous_tmp; do [ -e "$f" ] && fail "$f of the killed run is still there"; done
ls -A "$work/kill" "$work" | grep -q '\.tmp$' && fail "temporaries left at the end"
differ=0
for f in "$work/ref/"*.obj; do cmp -s "$f" "$work/kill/$(basename "$f")" || differ=$((differ + 1)); done
[ "$differ" -eq 0 ] || fail "$differ frame files differ from the uninterrupted run"
[ "$("$probe" "$work/kill/trajectory.h5")" = "$("$probe" "$work/ref/trajectory.h5")" ] \
    || fail "the resumed trajectory's last frame differs"
count=$(grep -c '"frame": ' "$work/kill.json")
[ "$count" -eq $((frames + 1)) ] || fail "the final stats have $count frames"
echo "kill_resume: $kills kills, every time readable to the last complete frame; no temporary" \
    "left; resumed run equal to the uninterrupted one bitwise ($(ls "$work/ref/"*.obj | wc -l)" \
    "frame files, trajectory, $count stats frames); $((SECONDS - start)) s in all"
