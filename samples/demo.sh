#!/usr/bin/env bash
# README command 1: install the dependencies, build, then run the main job on a bundled sample:
# bake the sample creature (surface + exact medial mesh) into one HDF5 file and inspect it.
# Outputs go to samples/out/. BUILD_DIR picks the build directory (default: build).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
bash "$root/.ci/install-deps.sh"
mkdir -p "$build"
cmake -S "$root" -B "$build" > "$build/configure.log" 2>&1 || { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" --target mat-bake mat-run

bake="$build/preprocess/mat-bake"
out="$root/samples/out"
mkdir -p "$out"
sample="$root/samples/creature/creature"
echo "== mat-bake check: what the bake will read"
"$bake" check "$sample.obj" --medial "$sample.ma"
echo "== mat-bake: bake the creature"
"$bake" "$sample.obj" --medial "$sample.ma" -o "$out/creature.h5"
echo "== mat-bake inspect"
"$bake" inspect "$out/creature.h5"
echo "demo: the bake is $out/creature.h5"
