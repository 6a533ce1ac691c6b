#!/usr/bin/env bash
# The GPU benchmark (docs/gpu.md; not a test): the sample creature (145 handles) baked at about
# 50k, 200k, 460k and 2M tets, then per bake the semi-reduced step at 10 iterations on the GPU
# against the CPU path on all cores of the same machine, in one run (gpu_bench: ms per step,
# median of ROUNDS rounds of STEPS steps, and each side's phase split).
# Usage: tests/bench/gpu_bench.sh [BUILD_DIR] [STEPS] [ROUNDS] [TET_SIZES...]
#   BUILD_DIR: a build with -DMAT_CUDA=ON (default build-cuda), or a folder holding mat-bake and
#   gpu_bench themselves (a bundle carried to a GPU machine). Tet sizes default to
#   0.0095 0.006 0.0045 0.00274 (fractions of the diagonal: ~50k, ~200k, ~460k, ~2.0M tets).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${1:-$root/build-cuda}"
steps="${2:-20}"
rounds="${3:-5}"
shift $(($# < 3 ? $# : 3))
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(0.0095 0.006 0.0045 0.00274)
if [ -x "$build/mat-bake" ]; then
    bake="$build/mat-bake" bench="$build/gpu_bench"
else
    bake="$build/preprocess/mat-bake" bench="$build/tests/bench/gpu_bench"
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# detail 5: 145 spheres (run_bench.sh's creature).
"$bake" --log-level warn sample creature --detail 5 -o "$work" > /dev/null
bakes=()
for size in "${sizes[@]}"; do
    start=$(date +%s%N)
    "$bake" --log-level warn --threads 0 "$work/creature/creature.obj" \
        --medial "$work/creature/creature.ma" -o "$work/creature_$size.h5" --tet-size "$size" \
        > /dev/null
    echo "baked tet size $size in $((($(date +%s%N) - start) / 1000000)) ms"
    bakes+=("$work/creature_$size.h5")
done
"$bench" --steps "$steps" --rounds "$rounds" "${bakes[@]}"
