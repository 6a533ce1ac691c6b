#!/usr/bin/env bash
# Cost of a scene with what moves (a scene should cost what moves in it, not what rests:
# docs/method.md, section 7): 20 creatures with collision on, 18 resting on the ground apart from
# each other and 2 dropped in the middle, one onto the other (the lower lands
# at about t = 2.6 s, the upper on it at about 3.1 s; solver.damping 0.1, which lets the resting
# ones settle within the warm-up, also caps the fall at about 3 m/s).
#   tests/bench/many_objects.sh [BUILD_DIR] [REPEATS] [SOLVERS]
# Runs many_objects_bench (see its header) REPEATS times (3 by default) on each of
#   (a) all 20 awake: solver.sleep_speed 0,
#   (b) sleeping on (the 18 resting creatures are asleep after the warm-up),
#   (c) the 2 moving creatures alone,
# for each solver mode in SOLVERS (a space-separated list, "semi" by default), with 60 warm-up
# steps (2 s) and 60 timed steps (2 s: the fall, the landings and the first rebounds).
# The machine may be shared: the load average is printed before and after.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
repeats="${2:-3}"
solvers="${3:-semi}"
bench="$build/tests/bench/many_objects_bench"
bake="$root/samples/creature/creature_coarse.h5"
[[ -x "$bench" ]] || { echo "many_objects.sh: $bench not built (MAT_BUILD_BENCHMARKS=ON)" >&2; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

material='"material": { "youngs_modulus": 5e5, "poisson_ratio": 0.4, "density": 1000 }'
# The movers: dropped from 7 m and 9.5 m, one above the other.
movers="{ \"name\": \"dropped_low\", \"bake\": \"$bake\", \"position\": [0, 7, 0],
      \"rotation_degrees\": [-90, 0, 0], $material },
    { \"name\": \"dropped_high\", \"bake\": \"$bake\", \"position\": [0.05, 9.5, 0],
      \"rotation_degrees\": [-80, 45, 0], $material }"
# The resting creatures: a 6 x 3 grid on the ground, 1.5 m apart, clear of the middle.
resting=""
for x in -3.75 -2.25 -0.75 0.75 2.25 3.75; do
    for z in -3.5 -2 2.5; do
        resting+="{ \"name\": \"rest_${x}_${z}\", \"bake\": \"$bake\", \"position\": [$x, 0.115, $z],
      \"rotation_degrees\": [-90, 0, 0], $material },
    "
    done
done

write_scene() { # FILE SLEEP_SPEED OBJECTS
    cat >"$1" <<JSON
{
  "time": { "dt": 0.0333333333, "iterations": 10 },
  "solver": { "collision": "bounded", "damping": 0.1, "sleep_speed": $2, "sleep_steps": 10 },
  "objects": [
    $3
  ],
  "colliders": [{ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "friction": 0.6 }]
}
JSON
}
write_scene "$work/a_all_awake.json" 0 "$resting$movers"
write_scene "$work/b_sleeping.json" 0.01 "$resting$movers"
write_scene "$work/c_movers_alone.json" 0.01 "$movers"

echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
for solver in $solvers; do
    for scene in a_all_awake b_sleeping c_movers_alone; do
        for ((r = 1; r <= repeats; ++r)); do
            echo -n "$solver $scene run $r: "
            MAT_THREADS="${MAT_THREADS:-2}" "$bench" "$work/$scene.json" 60 60 "$solver" |
                sed "s|$work/||"
        done
    done
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
