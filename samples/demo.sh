#!/usr/bin/env bash
# README command 1: install the dependencies, build, then run the main job on a bundled sample:
# bake the sample creature (surface + exact medial mesh) into one HDF5 file, run its scene (a
# drop onto the ground) and write frames: OBJ surfaces, a ParaView series (frames.pvd) and an
# HDF5 trajectory cache, with per-frame statistics. Outputs go to samples/out/creature/. Then
# three coarser creatures dropped onto each other and the ground (samples/creature_stack),
# with preview pictures: samples/out/creature_stack/.
# BUILD_DIR picks the build directory (default: build); FRAMES the number of frames (default:
# the scene's).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
bash "$root/.ci/install-deps.sh"
mkdir -p "$build"
cmake -S "$root" -B "$build" > "$build/configure.log" 2>&1 || { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" --target mat-bake mat-run

bake="$build/preprocess/mat-bake"
run="$build/runtime/mat-run"
sample="$root/samples/creature"
out="$root/samples/out/creature"
mkdir -p "$out"
echo "== mat-bake check: what the bake will read"
"$bake" check "$sample/creature.obj" --medial "$sample/creature.ma"
echo "== mat-bake: bake the creature"
"$bake" "$sample/creature.obj" --medial "$sample/creature.ma" -o "$out/creature.h5"
"$bake" inspect "$out/creature.h5"
echo "== mat-run: drop it on the ground"
# The scene names its bake relative to itself: run a copy of it next to the bake, writing OBJ
# frames, a VTU series with velocity and stretch, and the HDF5 trajectory.
sed -e 's/"output": *{[^}]*}/"output": { "format": ["obj", "vtu", "h5"], "every": 1, "fields": ["velocity", "stretch"] }/' \
    "$sample/scene.json" > "$out/scene.json"
frames=()
[ -n "${FRAMES:-}" ] && frames=(--frames "$FRAMES")
"$run" "$out/scene.json" -o "$out/frames" --stats "$out/stats.json" "${frames[@]}"
echo "demo: frames in $out/frames (creature_*.obj, frames.pvd for ParaView, trajectory.h5),"
echo "      statistics in $out/stats.json"

echo "== mat-bake: a coarser creature (tets 4% of its diagonal) for a pile"
stack="$root/samples/out/creature_stack"
mkdir -p "$stack"
"$bake" "$sample/creature.obj" --medial "$sample/creature.ma" -o "$stack/creature_coarse.h5" \
    --tet-size 0.04
echo "== mat-run: three creatures dropped onto each other and the ground (contact between bodies)"
sed -e 's#"\.\./creature/creature_coarse\.h5"#"creature_coarse.h5"#' \
    "$root/samples/creature_stack/scene.json" > "$stack/scene.json"
"$run" "$stack/scene.json" -o "$stack/frames" --stats "$stack/stats.json" --preview \
    --preview-size 480x360 "${frames[@]}"
echo "demo: the pile's frames in $stack/frames (bottom_*.obj, middle_*.obj, top_*.obj), pictures"
echo "      in $stack/frames/preview, statistics in $stack/stats.json"
