#!/usr/bin/env bash
# The contact solve's cost against the rest of the step (docs/method.md, section 5, "Not done
# yet"): runs samples/creatures_collide (its committed bake, 60 frames) ROUNDS times (default 5)
# in each solver mode given (default: semi), and prints per round and as medians the ms per step
# of collision detection, of the contact solve, and of the rest of the solver step (local step,
# right-hand side, solve, reconstruction, acceleration), from mat-run's phase table.
#   tests/bench/contact_cost.sh [BUILD_DIR] [THREADS] [ROUNDS] [MODES...]
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-2}"
rounds="${3:-5}"
shift $(($# < 3 ? $# : 3))
modes=("${@:-semi}")
run="$build/runtime/mat-run"
[ -x "$run" ] || { echo "contact_cost: no $run (build first)" >&2; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Rounds alternate over the modes, so that a slow phase of the machine spreads over all of them.
for ((round = 1; round <= rounds; ++round)); do
    for mode in "${modes[@]}"; do
        "$run" "$root/samples/creatures_collide/scene.json" --solver "$mode" --threads "$threads" \
            -o "$work/out" > "$work/log" 2>&1
        awk -v mode="$mode" -v round="$round" '
            /^local step/ { rest += $4 } /^global: right-hand side/ { rest += $5 }
            /^global: solve/ { rest += $4 } /^global: reconstruct/ { rest += $4 }
            /^acceleration/ { rest += $3 }
            /^collision \(detection\)/ { detection = $4 } /^collision \(contact\)/ { contact = $4 }
            END { print mode, round, detection, contact, rest }' "$work/log" >> "$work/rounds"
    done
done
echo "== creatures_collide, $threads threads, ms per step"
printf "%-7s%7s%12s%10s%8s%14s\n" mode round detection contact rest contact/rest
awk '{ printf "%-7s%7d%12.3f%10.3f%8.3f%14.2f\n", $1, $2, $3, $4, $5, $4 / $5 }' "$work/rounds"
for mode in "${modes[@]}"; do
    awk -v mode="$mode" '
        function median(v, k,    i, j, x) {
            for (i = 2; i <= k; ++i) { x = v[i]; for (j = i - 1; j >= 1 && v[j] > x; --j) v[j + 1] = v[j]; v[j + 1] = x }
            return k % 2 ? v[(k + 1) / 2] : (v[k / 2] + v[k / 2 + 1]) / 2
        }
        $1 == mode { ++n; d[n] = $3; c[n] = $4; r[n] = $5; q[n] = $4 / $5 }
        END { printf "%-7s%7s%12.3f%10.3f%8.3f%14.2f\n", mode, "median", median(d, n), median(c, n), median(r, n), median(q, n) }' \
        "$work/rounds"
done
