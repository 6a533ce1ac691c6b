#!/usr/bin/env bash
# The bake benchmark (docs/method.md, section 7; not a test): time and peak memory of every stage
# of mat-bake on the sample creature at about 50k tets with 100-200 handles, on the threads given
# (default 2).
# Usage: tests/bench/bake_bench.sh [BUILD_DIR] [THREADS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-2}"
bake="$build/preprocess/mat-bake"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# detail 4: 121 spheres (6 limbs of 18 cones and a slab body); tet size 0.0095 -> ~50k tets.
"$bake" --log-level warn sample creature --detail 4 -o "$work" > /dev/null
"$bake" --log-level warn --threads "$threads" "$work/creature/creature.obj" \
    --medial "$work/creature/creature.ma" -o "$work/creature.h5" --tet-size 0.0095
/usr/bin/time -f "whole process: %e s wall, %M KB peak RSS" \
    "$bake" --log-level warn --threads "$threads" "$work/creature/creature.obj" \
    --medial "$work/creature/creature.ma" -o "$work/creature.h5" --tet-size 0.0095 > /dev/null
