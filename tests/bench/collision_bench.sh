#!/usr/bin/env bash
# Collision world per step on two creatures of about 270 primitives each in contact, 2 threads.
#   tests/bench/collision_bench.sh [BUILD_DIR] [STEPS] [REPEATS] [ROUNDS] [EDGE_CONTACTS]
# Bakes the creature sample's surface with a generated 230-sphere medial mesh (267 primitives;
# --weights-per-node 16: with 8 this medial mesh gives a rank-deficient basis), drops one
# creature on the other for STEPS steps (25 by default: the two then press into each other,
# about 170 triangle pairs intersecting; by 40 they have come apart), then runs collision_bench
# (see its header) ROUNDS times (default 5), the last under perf stat when perf is available,
# for the process CPU time. Prints the last round in full, then per round and over the rounds
# (median, min, max) the bounded pipeline's wall ms per step and the two ratios: the VM's speed
# drifts by 15-50% over seconds to minutes, so one round can land in a slow state.
# SELF_COLLISION=off measures the pairs between the two bodies only (the scene's
# solver.self_collision; default on, as mat-run's default).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
steps="${2:-25}"
repeats="${3:-200}"
rounds="${4:-5}"
edges="${5:-off}" # solver.edge_contacts: on or off
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

"$build/preprocess/mat-bake" "$root/samples/creature/creature.obj" --spheres 230 \
    --weights-per-node 16 -o "$work/creature.h5" --threads 2 --log-level warn
cat >"$work/scene.json" <<JSON
{
  "time": { "dt": 0.0166666667, "iterations": 10 },
  "solver": { "collision": "bounded", "edge_contacts": "$edges", "self_collision": "${SELF_COLLISION:-on}" },
  "objects": [
    { "name": "lower", "bake": "creature.h5", "position": [0, 0.44, 0] },
    { "name": "upper", "bake": "creature.h5", "position": [0.05, 1.15, 0],
      "rotation_degrees": [0, 30, 0] }
  ],
  "colliders": [{ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.6 }]
}
JSON
bench=("$build/tests/bench/collision_bench" "$work/scene.json" "$steps" "$repeats")
for ((round = 1; round <= rounds; ++round)); do
    if ((round == rounds)) && command -v perf >/dev/null && perf stat -e task-clock true >/dev/null 2>&1; then
        MAT_THREADS=2 perf stat -e task-clock,context-switches "${bench[@]}" > "$work/log" 2>&1
    else
        MAT_THREADS=2 "${bench[@]}" > "$work/log" 2>&1
    fi
    if ((round == rounds)); then cat "$work/log"; fi
    # "medial, bounded  <phases> | wall cpu | ..."; "ratio (a) ...: wall X, cpu Y".
    awk -v r="$round" '
        /^medial, bounded/ { split($0, part, "|"); split(part[2], w, " "); wall = w[1] }
        /^ratio \(a\)/ { a = $7; sub(",", "", a) }
        /^ratio \(b\)/ { b = $8; sub(",", "", b) }
        END { print r, wall, a, b }' "$work/log" >> "$work/rounds"
done
echo "== bounded collision, wall ms per step (response excluded), over $rounds rounds"
awk -v n="$rounds" '
    { wall[NR] = $2; a[NR] = $3; b[NR] = $4 }
    function median(v, k,    i, j, x) { # sorts v[1..k] (insertion), returns the median
        for (i = 2; i <= k; ++i) { x = v[i]; for (j = i - 1; j >= 1 && v[j] > x; --j) v[j + 1] = v[j]; v[j + 1] = x }
        return k % 2 ? v[(k + 1) / 2] : (v[k / 2] + v[k / 2 + 1]) / 2
    }
    END {
        printf "%-8s%10s%16s%16s\n", "round", "bounded", "all-pairs/b.", "CGAL/bounded"
        for (r = 1; r <= NR; ++r) printf "%-8d%10.3f%16.2f%16.2f\n", r, wall[r], a[r], b[r]
        mw = median(wall, NR); ma = median(a, NR); mb = median(b, NR)
        printf "%-8s%10.3f%16.2f%16.2f\n", "median", mw, ma, mb
        printf "%-8s%10.3f%16.2f%16.2f\n", "min", wall[1], a[1], b[1]
        printf "%-8s%10.3f%16.2f%16.2f\n", "max", wall[NR], a[NR], b[NR]
    }' "$work/rounds"
