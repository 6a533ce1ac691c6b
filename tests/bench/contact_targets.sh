#!/usr/bin/env bash
# Penetration and strain under contact (docs/method.md, section 5): the collision samples
# (creatures_collide, drop_on_pile, limb_self_contact, kinematic_sweep) and the stability study's
# projectile, each run as committed in every solver mode with --check-collisions, and for each
# run one line:
#   pen_%      the deepest surface vertex inside another body or (self) inside its own body, over
#              every step, as a percentage of the smaller body's bounding-box diagonal (mat-bake
#              inspect); the bound asked of contact is 0.5;
#   pen_mm     the same in mm, then self_mm, its part within one body;
#   pairs10    intersecting triangle pairs between bodies or between primitives of one body that
#              share no sphere, summed over the last 10 frames (asked: 0), then self10, the part
#              within one body;
#   strain     the largest max_strain over the frames and bodies (asked: at most 1.0 in
#              creatures_collide and drop_on_pile);
#   rise       the largest rise of the total energy above its lowest so far, J;
# then per scene the largest strain of the semi-reduced runs over the full-space ones (asked: at
# most 1.5), and a line for each run or scene that misses one of these bounds (exit status 1 if
# any does, else 0). Runs can vary the friction as the studies in docs/method.md do: K0..K1 multiply every
# friction coefficient of the scene by 1 + 0.01 k (default k = 0 only: the scenes as committed).
#   tests/bench/contact_targets.sh [BUILD_DIR] [THREADS] [K0] [K1]
#   MODES="semi full" SCENES="creatures_collide" tests/bench/contact_targets.sh ...
#   SOLVER='{"contact_skin": 0.25}' tests/bench/contact_targets.sh ...   keys merged into every
#                                                     scene's "solver" block
#   MATERIAL='{"strain_limits": [0.2, 1.8]}' ...      keys merged into every object's "material"
# A run with 1 thread gives the same figures as with more (the solvers are deterministic for
# any thread count); each takes seconds to a minute (the check is exhaustive).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-1}"
k0="${3:-0}"
k1="${4:-$k0}"
modes=(${MODES:-semi full hyper})
scenes=(${SCENES:-creatures_collide drop_on_pile limb_self_contact kinematic_sweep projectile})
run="$build/runtime/mat-run"
bake="$build/preprocess/mat-bake"
for tool in "$run" "$bake"; do
    [ -x "$tool" ] || { echo "contact_targets: no $tool (build first)" >&2; exit 1; }
done
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

scene_file() { # scene_file NAME
    if [ "$1" = projectile ]; then
        echo "$root/samples/stability/projectile_bounded.json"
    else
        echo "$root/samples/$1/scene.json"
    fi
}

# The scene with its bakes' paths made absolute and every friction times 1 + 0.01 k; prints the
# bakes, one per line.
prepare() { # prepare SCENE_FILE K OUT
    python3 - "$1" "$2" "$3" "${SOLVER:-{\}}" "${MATERIAL:-{\}}" <<'PY'
import json, os, sys
path, k, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
scene = json.load(open(path))
here = os.path.dirname(os.path.abspath(path))
factor = 1.0 + 0.01 * k
solver = scene.setdefault("solver", {})
solver.update(json.loads(sys.argv[4]))
if "collision_friction" in solver:
    solver["collision_friction"] *= factor
elif k != 0:
    solver["collision_friction"] = 0.3 * factor  # mat-run's default
for collider in scene.get("colliders", []):
    if "friction" in collider:
        collider["friction"] *= factor
for obj in scene["objects"]:
    obj["bake"] = os.path.normpath(os.path.join(here, obj["bake"]))
    obj.setdefault("material", {}).update(json.loads(sys.argv[5]))
    print(obj["bake"])
scene.pop("output", None)
json.dump(scene, open(out, "w"))
PY
}

printf "%-18s %-6s %3s %7s %8s %8s %8s %7s %7s %7s\n" scene mode k pen_% pen_mm self_mm pairs10 \
    self10 strain rise
for name in "${scenes[@]}"; do
    file="$(scene_file "$name")"
    for ((k = k0; k <= k1; ++k)); do
        prepare "$file" "$k" "$work/scene.json" > "$work/bakes"
        diagonal=$(sort -u "$work/bakes" | while read -r b; do
            "$bake" inspect "$b" | sed -n 's/.*bounding-box diagonal \([0-9.e+-]*\).*/\1/p'
        done | sort -g | head -1)
        for mode in "${modes[@]}"; do
            "$run" "$work/scene.json" --solver "$mode" --threads "$threads" --check-collisions \
                --stats "$work/stats.json" -o "$work/out" --log-level warn > /dev/null
            python3 - "$work/stats.json" "$name" "$mode" "$k" "$diagonal" <<'PY' | tee -a "$work/lines"
import json, sys
stats, name, mode, k, diagonal = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5])
frames = json.load(open(stats))["frames"]
checks = [f.get("collision_check", {}) for f in frames]
pen = max(c.get("max_penetration", 0.0) for c in checks)
self_pen = max(c.get("max_self_penetration", 0.0) for c in checks)
pairs = sum(c.get("far_pairs", 0) for c in checks[-10:])
self_pairs = sum(c.get("self_pairs", 0) for c in checks[-10:])
strain = max(b["max_strain"] for f in frames for b in f["bodies"])
energy = [sum(b["energy"]["total"] for b in f["bodies"]) for f in frames]
rise = max(e - min(energy[:i + 1]) for i, e in enumerate(energy))
print("%-18s %-6s %3s %7.3f %8.2f %8.2f %8d %7d %7.3f %7.2f" % (name, mode, k,
      100.0 * max(pen, self_pen) / diagonal, 1e3 * max(pen, self_pen), 1e3 * self_pen, pairs,
      self_pairs, strain, rise))
PY
        done
    done
done
echo "== largest strain, semi-reduced over full space (over the k's run)"
awk '{ key = $1 " " $2; if (!(key in most) || $9 > most[key]) most[key] = $9; seen[$1] = 1 }
     END { for (s in seen) if ((s " semi") in most && (s " full") in most && most[s " full"] > 0)
               printf "%-18s %.3f / %.3f = %.2f\n", s, most[s " semi"], most[s " full"],
                   most[s " semi"] / most[s " full"] }' "$work/lines" | sort
# The bounds asked of contact: one line per run or scene that misses one; exit 1 if any does.
echo "== runs and scenes over the bounds (penetration 0.5%, pairs at rest 0; strain 1.0 and semi/full 1.5 in creatures_collide and drop_on_pile)"
awk '{ run = $1 " " $2 " k=" $3
       if ($4 > 0.5) { print run ": penetration " $4 "%"; missed = 1 }
       if ($7 > 0) { print run ": " $7 " pairs at rest"; missed = 1 }
       named = $1 == "creatures_collide" || $1 == "drop_on_pile"
       if (named && $9 > 1.0) { print run ": strain " $9; missed = 1 }
       key = $1 " " $2; if (!(key in most) || $9 > most[key]) most[key] = $9 }
     END { for (key in most) {
               split(key, part, " ")
               if (part[2] != "semi" || !((part[1] " full") in most) || most[part[1] " full"] <= 0)
                   continue
               named = part[1] == "creatures_collide" || part[1] == "drop_on_pile"
               if (named && most[key] > 1.5 * most[part[1] " full"]) {
                   print part[1] ": semi-reduced strain " most[key] " over 1.5 x full " most[part[1] " full"]
                   missed = 1
               }
           }
           exit missed }' "$work/lines"
