#!/usr/bin/env bash
# The GPU step's checks and timings on a machine with a GPU, in one run (docs/gpu.md; not a
# test: CI has no GPU):
#   1. the GPU tests (test_runtime_gpu: GPU against CPU on the sample creature);
#   2. mat-run --device cpu against --device cuda on samples/creature (ground contact) and
#      samples/creature_stack (contacts between bodies, detection every step): each body's last
#      frame, max vertex distance between the two runs;
#   3. tests/bench/gpu_bench.sh (ms per step at about 50k, 200k, 460k and 2.0M tets, GPU against
#      the CPU path on all cores, per launch variant).
# Usage: tests/bench/gpu_device_check.sh BIN [OUT_DIR] [FRAMES] [STEPS] [ROUNDS]
#   BIN: a folder holding mat-bake, mat-run, gpu_bench and test_runtime_gpu, built with
#   -DMAT_CUDA=ON (the bundle of ../shared/tools/device-bundle.sh, unpacked). Logs go to OUT_DIR
#   (default: a new temporary folder). The samples' bakes are made with BIN's mat-bake where
#   they are missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin="$(cd "$1" && pwd)"
out="${2:-$(mktemp -d)}"
frames="${3:-30}"
steps="${4:-10}"
rounds="${5:-3}"
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv,noheader \
    || true
echo "== GPU tests"
"$bin/test_runtime_gpu" > "$out/tests.log" 2>&1 || { tail -40 "$out/tests.log"; exit 1; }
grep -E "^(free spin|exact projections|pinned)|PASSED|SKIPPED|FAILED" "$out/tests.log"

echo "== mat-run, --device cpu against --device cuda, $frames frames"
for bake in creature/creature.h5 creature/creature_coarse.h5; do
    [ -f "$root/samples/$bake" ] \
        || make -s -C "$root/samples" MAT_BAKE="$bin/mat-bake" "$bake" > /dev/null
done
for scene in creature creature_stack; do
    # The GPU steps keep the angular momentum implicit Euler gives (docs/gpu.md): both runs do.
    python3 - "$root/samples/$scene/scene.json" "$out/$scene.json" << 'PYTHON'
import json, os, sys
scene = json.load(open(sys.argv[1]))
for body in scene["objects"]:
    body["bake"] = os.path.normpath(os.path.join(os.path.dirname(sys.argv[1]), body["bake"]))
scene.setdefault("solver", {})["angular_momentum"] = "integrator"
json.dump(scene, open(sys.argv[2], "w"), indent=1)
PYTHON
    for device in cpu cuda; do
        "$bin/mat-run" --log-level warn "$out/$scene.json" --frames "$frames" \
            --device "$device" -o "$out/$scene-$device" > "$out/$scene-$device.log" 2>&1 \
            || { tail -5 "$out/$scene-$device.log"; exit 1; }
    done
    python3 - "$out/$scene-cpu" "$out/$scene-cuda" "$scene" "$frames" << 'PYTHON'
import glob, math, os, sys
cpu, cuda, scene, frames = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
def vertices(path):
    return [tuple(map(float, line.split()[1:4])) for line in open(path) if line.startswith("v ")]
for path in sorted(glob.glob(os.path.join(cpu, "*_%05d.obj" % frames))):
    a, b = vertices(path), vertices(os.path.join(cuda, os.path.basename(path)))
    assert len(a) == len(b) and a, path
    distance = max(math.dist(p, q) for p, q in zip(a, b))
    print("%s: %s, frame %d: max vertex distance %.3g m"
          % (scene, os.path.basename(path), frames, distance))
PYTHON
done

echo "== gpu_bench.sh, $steps steps, $rounds rounds"
"$root/tests/bench/gpu_bench.sh" "$bin" "$steps" "$rounds" 2>&1 | tee "$out/bench.log"
