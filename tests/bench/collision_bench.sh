#!/usr/bin/env bash
# Collision world per step on two creatures of about 270 primitives each in contact, 2 threads.
#   tests/bench/collision_bench.sh [BUILD_DIR] [STEPS] [REPEATS]
# Bakes the creature sample's surface with a generated 230-sphere medial mesh (267 primitives;
# --weights-per-node 16: with 8 this medial mesh gives a rank-deficient basis), drops one
# creature on the other for STEPS steps (25 by default: the two then press into each other,
# about 170 triangle pairs intersecting; by 40 they have come apart), then runs collision_bench
# (see its header) under perf stat when perf is available, for the process CPU time.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
steps="${2:-25}"
repeats="${3:-50}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

"$build/preprocess/mat-bake" "$root/samples/creature/creature.obj" --spheres 230 \
    --weights-per-node 16 -o "$work/creature.h5" --threads 2 --log-level warn
cat >"$work/scene.json" <<JSON
{
  "time": { "dt": 0.0166666667, "iterations": 10 },
  "solver": { "collision": "bounded" },
  "objects": [
    { "name": "lower", "bake": "creature.h5", "position": [0, 0.44, 0] },
    { "name": "upper", "bake": "creature.h5", "position": [0.05, 1.15, 0],
      "rotation_degrees": [0, 30, 0] }
  ],
  "colliders": [{ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.6 }]
}
JSON
bench=("$build/tests/bench/collision_bench" "$work/scene.json" "$steps" "$repeats")
if command -v perf >/dev/null && perf stat -e task-clock true >/dev/null 2>&1; then
    MAT_THREADS=2 perf stat -e task-clock,context-switches "${bench[@]}"
else
    MAT_THREADS=2 "${bench[@]}"
fi
