#!/usr/bin/env bash
# run_collision_scene.sh MAT_RUN SCENE_DIR BAKE_DIR WORK_DIR FRAMES
# Runs a collision sample scene (its bakes are other samples', e.g. ../creature/creature_coarse.h5)
# for a few frames with --check-collisions: each bake the scene names is replaced by the coarse
# test bake of its sample (BAKE_DIR/<sample>.h5, <sample> the bake's directory), placed where
# the scene expects it. Checks that the run succeeds, that every intersecting triangle pair in
# different bodies or non-adjacent primitives was found, and that the stats have the check.
set -euo pipefail
run="$1"; scene_dir="$2"; bakes="$3"; work="$4"; frames="$5"
name="$(basename "$scene_dir")"
rm -rf "$work"; mkdir -p "$work/$name"
cp "$scene_dir/scene.json" "$work/$name/scene.json"
for b in $(grep -o '"bake": *"[^"]*"' "$work/$name/scene.json" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
    sample="$(basename "$(dirname "$b")")"
    mkdir -p "$(dirname "$work/$name/$b")"
    cp "$bakes/$sample.h5" "$work/$name/$b"
done
"$run" "$work/$name/scene.json" -o "$work/out" --frames "$frames" --stats "$work/stats.json" \
    --threads 2 --check-collisions | tee "$work/log.txt"
status=0
grep -q "recall 100.000% on pairs in different bodies or non-adjacent primitives" "$work/log.txt" \
    || { echo "FAIL: the collision world missed intersecting triangle pairs"; status=1; }
grep -q '"collision_check"' "$work/stats.json" || { echo "FAIL: stats without collision_check"; status=1; }
ls -A "$work/out" | grep -q '\.tmp$' && { echo "FAIL: temporary files left"; status=1; }
exit $status
