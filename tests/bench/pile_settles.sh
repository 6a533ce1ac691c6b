#!/usr/bin/env bash
# A pile of 10 bodies settles (docs/method.md, section 5): ten rounded bars (the rounded_bar
# sample baked at --tet-size 0.1: 518 tets, 4 handles) stacked as a crib, five layers of two
# crosswise bars 2 mm apart, dropped onto the ground (friction 0.5 on the ground and between the
# bodies, dt 1/30 s, 10 iterations, sleeping off so that no body is frozen). After 3 s the total
# kinetic energy must be below 1e-4 of its peak and no body's centroid may move more than 1 mm
# over the last second. Runs every solver mode at E = 1e5 and 1e6 Pa and prints one line each,
# then exits non-zero if any misses either bound.
#   tests/bench/pile_settles.sh [BUILD_DIR] [THREADS]
#   ANGULAR_MOMENTUM=keep tests/bench/pile_settles.sh ...   with that solver.angular_momentum
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build}"
threads="${2:-2}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

"$build/preprocess/mat-bake" "$root/samples/rounded_bar/rounded_bar.obj" \
    --medial "$root/samples/rounded_bar/rounded_bar.ma" --tet-size 0.1 -o "$work/bar.h5" \
    --log-level warn > /dev/null

scene() { # scene YOUNGS_MODULUS
    python3 - "$1" "${ANGULAR_MOMENTUM:-}" <<'PY'
import json, sys
objects = []
y = 0.082
for layer in range(5):
    for i in range(2):
        offset = (i - 0.5) * 0.40
        position, rotation = ([0.0, y, offset], [90, 0, 0]) if layer % 2 == 0 \
            else ([offset, y, 0.0], [90, 90, 0])
        objects.append({"name": "b%d" % len(objects), "bake": "bar.h5", "position": position,
                        "rotation_degrees": rotation,
                        "material": {"youngs_modulus": float(sys.argv[1]), "poisson_ratio": 0.3,
                                     "density": 1000}})
    y += 0.164
print(json.dumps({"time": {"dt": 0.0333333333, "frames": 90, "iterations": 10},
                  "gravity": [0, -9.81, 0],
                  "solver": dict({"collision": "bounded", "collision_friction": 0.5, "sleep_speed": 0},
                                 **({"angular_momentum": sys.argv[2]} if sys.argv[2] else {})),
                  "objects": objects,
                  "colliders": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0],
                                 "friction": 0.5}],
                  "output": {"format": "obj", "every": 1}}, indent=1))
PY
}

status=0
for modulus in 1e5 1e6; do
    scene "$modulus" > "$work/scene.json"
    for mode in semi full hyper; do
        out="$work/out.$modulus.$mode"
        "$build/runtime/mat-run" "$work/scene.json" -o "$out" --solver "$mode" \
            --threads "$threads" --stats "$out.json" --log-level warn > /dev/null
        python3 - "$out" "$modulus" "$mode" <<'PY' || status=1
import json, math, sys
out, modulus, mode = sys.argv[1:4]
frames = json.load(open(out + ".json"))["frames"]
kinetic = [sum(b["energy"]["kinetic"] for b in f["bodies"]) for f in frames]
peak = max(kinetic)
last = len(frames) - 1
second = round(1.0 / (frames[1]["time"] - frames[0]["time"]))
def centroid(body, frame):
    vs = [list(map(float, l.split()[1:4])) for l in open("%s/b%d_%05d.obj" % (out, body, frame))
          if l.startswith("v ")]
    return [sum(v[i] for v in vs) / len(vs) for i in range(3)]
drift = max(math.dist(centroid(b, last - second), centroid(b, last)) for b in range(10))
ok = kinetic[-1] < 1e-4 * peak and drift < 1e-3
print("E %s %-5s: kinetic energy at %.2f s %.3g of its peak (%.4g J), largest centroid drift "
      "over the last second %.3f mm: %s" % (modulus, mode, frames[-1]["time"], kinetic[-1] / peak,
                                             peak, 1000 * drift, "settled" if ok else "NOT SETTLED"))
sys.exit(0 if ok else 1)
PY
    done
done
exit "$status"
