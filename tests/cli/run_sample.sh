#!/usr/bin/env bash
# run_sample.sh MAT_RUN SAMPLE_DIR BAKE WORK_DIR FRAMES [MAT_RUN_OPTIONS...]
# Runs a sample scene for a few frames on a given (coarse) bake: copies the scene next to the
# bake under the name the scene expects, runs mat-run with every output format and --stats, and
# checks that every frame file, the collection, the trajectory cache and the stats are there.
set -euo pipefail
run="$1"; sample_dir="$2"; bake="$3"; work="$4"; frames="$5"
shift 5 # the rest: more mat-run options (e.g. --solver hyper)
name="$(basename "$sample_dir")"
rm -rf "$work"; mkdir -p "$work"
# The scene with every output format and field switched on (its other keys as shipped).
sed -e 's/"output": *{[^}]*}/"output": { "format": ["obj", "ply", "vtu", "h5"], "every": 1, "fields": ["velocity", "stretch"] }/' \
    "$sample_dir/scene.json" > "$work/scene.json"
grep -q '"vtu"' "$work/scene.json" || { echo "FAIL: could not set the output formats"; exit 1; }
# Every bake the scene names is this sample's coarse bake.
for b in $(grep -o '"bake": *"[^"]*"' "$work/scene.json" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
    cp "$bake" "$work/$b"
done
"$run" "$work/scene.json" -o "$work/out" --frames "$frames" --stats "$work/stats.json" --threads 2 "$@"
status=0
objects=$(grep -o '"name": *"[^"]*"' "$work/scene.json" | sed 's/.*"\([^"]*\)"$/\1/')
for object in $objects; do
    for ext in obj ply vtu; do
        count=$(ls "$work/out" | grep -c "^${object}_[0-9]*\.${ext}$" || true)
        if [ "$count" -ne $((frames + 1)) ]; then
            echo "FAIL: $count $ext frames of $object, expected $((frames + 1))"; status=1
        fi
    done
done
for f in frames.pvd trajectory.h5; do
    [ -s "$work/out/$f" ] || { echo "FAIL: no $f"; status=1; }
done
grep -q '"max_strain"' "$work/stats.json" || { echo "FAIL: stats without max_strain"; status=1; }
if grep -Eqi '(nan|inf)' "$work/out/${objects%% *}_$(printf %05d "$frames").obj"; then
    echo "FAIL: non-finite coordinates in the last frame"; status=1
fi
ls -A "$work/out" | grep -q '\.tmp$' && { echo "FAIL: temporary files left"; status=1; }
exit $status
