#!/usr/bin/env bash
# The run benchmark (issue 4; not a test): ms per step of semi-reduced against full-space (and
# hyper-reduced: the local step on sampled tets) projective dynamics at 10 iterations, on the
# sample creature at about 50k tets with about 150 handles, on the threads given (default 2),
# with the time per phase and the peak RSS of each.
# The creature falls freely (no ground: this measures the solver; contact is issue 5's bench).
# Usage: tests/bench/run_bench.sh [BUILD_DIR] [THREADS] [STEPS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-2}"
steps="${3:-30}"
bake="$build/preprocess/mat-bake"
run="$build/runtime/mat-run"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# detail 5: 145 spheres; tet size 0.0095 -> ~50k tets.
"$bake" --log-level warn sample creature --detail 5 -o "$work" > /dev/null
"$bake" --log-level warn --threads "$threads" "$work/creature/creature.obj" \
    --medial "$work/creature/creature.ma" -o "$work/creature.h5" --tet-size 0.0095 > /dev/null
cat > "$work/scene.json" <<SCENE
{
  "time": { "dt": 0.0333333333, "frames": 1, "iterations": 10 },
  "objects": [
    {
      "name": "creature", "bake": "creature.h5", "angular_velocity": [0, 2, 1],
      "material": { "youngs_modulus": 5e4, "poisson_ratio": 0.4, "density": 1000 }
    }
  ],
  "output": { "format": "obj", "every": $steps }
}
SCENE
for solver in semi full hyper; do
    echo "== $solver, $threads threads, $steps steps"
    "$run" --log-level info --threads "$threads" "$work/scene.json" -o "$work/out-$solver" \
        --solver "$solver" 2>&1 | grep -v "^\[info\] .*scene.json"
done
