#!/usr/bin/env bash
# The run benchmark (docs/method.md, section 7; not a test): ms per step of semi-reduced against
# full-space (and hyper-reduced: the local step on sampled tets) projective dynamics at 10
# iterations, on the sample creature at about 50k tets with about 150 handles, on the threads given
# (default 2), with the time per phase and the peak RSS of each.
# The creature falls freely (no ground: this measures the solver; collision and contact are
# measured by collision_bench.sh).
# The solvers run in turn, ROUNDS times (default 5): the VM's speed drifts by 15-50% over
# seconds to minutes, so one run of each can land in different states. Prints each solver's
# phase table from the last round, then per round and over the rounds (median, min, max) the
# solver's ms per step (the table's total minus export, preview and measures: writing the two
# OBJ frames costs about 0.3 ms per step averaged over 30 steps, alike for every solver) and the
# full / semi ratio of the same round.
# Usage: tests/bench/run_bench.sh [BUILD_DIR] [THREADS] [STEPS] [ROUNDS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-2}"
steps="${3:-30}"
rounds="${4:-5}"
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
  "solver": { "self_collision": "off" },
  "objects": [
    {
      "name": "creature", "bake": "creature.h5", "angular_velocity": [0, 2, 1],
      "material": { "youngs_modulus": 5e4, "poisson_ratio": 0.4, "density": 1000 }
    }
  ],
  "output": { "format": "obj", "every": $steps }
}
SCENE
solvers=(semi full hyper)
for ((round = 1; round <= rounds; ++round)); do
    for solver in "${solvers[@]}"; do
        "$run" --log-level info --threads "$threads" "$work/scene.json" -o "$work/out-$solver" \
            --solver "$solver" 2>&1 | grep -v "^\[info\] .*scene.json" > "$work/log-$solver"
        # The solve's ms per step: the phase table's total ("total  seconds  ms/step  100.0")
        # minus the rows that are not the solver's (the frames written at steps 0 and STEPS,
        # the preview and the measures: the same for every solver).
        awk -v r="$round" -v s="$solver" '
            /^export / || /^preview / || /^measures / { other += $(NF - 1) }
            /^total / { total = $(NF - 1) }
            END { print r, s, total - other }' "$work/log-$solver" >> "$work/rounds"
    done
done
for solver in "${solvers[@]}"; do
    echo "== $solver, $threads threads, $steps steps (round $rounds of $rounds)"
    cat "$work/log-$solver"
done
echo "== solver ms per step (total minus export) over $rounds rounds ($threads threads, $steps steps, 10 iterations)"
awk -v n="$rounds" '
    { t[$2, $1] = $3 }
    function median(a, k,    i, j, x) { # sorts a[1..k] (insertion), returns the median
        for (i = 2; i <= k; ++i) { x = a[i]; for (j = i - 1; j >= 1 && a[j] > x; --j) a[j + 1] = a[j]; a[j + 1] = x }
        return k % 2 ? a[(k + 1) / 2] : (a[k / 2] + a[k / 2 + 1]) / 2
    }
    END {
        printf "%-6s", "round"; printf "%10s%10s%10s%12s\n", "semi", "full", "hyper", "full/semi"
        for (r = 1; r <= n; ++r) {
            ratio[r] = t["full", r] / t["semi", r]
            printf "%-6d%10.2f%10.2f%10.2f%12.2f\n", r, t["semi", r], t["full", r], t["hyper", r], ratio[r]
        }
        split("semi full hyper", names, " ")
        for (stat = 1; stat <= 3; ++stat) {
            label = stat == 1 ? "median" : stat == 2 ? "min" : "max"
            printf "%-6s", label
            for (s = 1; s <= 3; ++s) {
                for (r = 1; r <= n; ++r) v[r] = t[names[s], r]
                m = median(v, n)
                printf "%10.2f", stat == 1 ? m : stat == 2 ? v[1] : v[n]
            }
            for (r = 1; r <= n; ++r) v[r] = ratio[r]
            m = median(v, n)
            printf "%12.2f\n", stat == 1 ? m : stat == 2 ? v[1] : v[n]
        }
    }' "$work/rounds"
