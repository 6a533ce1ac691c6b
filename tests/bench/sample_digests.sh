#!/usr/bin/env bash
# sample_digests.sh BUILD_DIR OUT_DIR: runs the sample scenes for a few frames in every solver
# mode (semi, full, hyper; collision scenes with --check-collisions) and writes OUT_DIR/digest.txt:
# per run, a hash of every output frame file and a hash of the --stats JSON without its timings.
# Two builds whose digests are equal write the same frames and statistics: the check that a
# refactor changed no output (diff the two digest.txt files). The run's checkpoint.h5 (for
# --resume) is state, not output: it is left out. Needs the samples' bakes
# (make -C samples; the collision scenes use creature/creature_coarse.h5, made by
# samples/demo.sh or `mat-bake samples/creature/creature.obj --medial samples/creature/creature.ma
# --tet-size 0.04 -o samples/creature/creature_coarse.h5`).
set -uo pipefail
build="$1"
out="$2"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
run="$build/runtime/mat-run"
mkdir -p "$out"
status=0
for scene in creature capsule rounded_bar torus creatures_collide limb_self_contact drop_on_pile \
    kinematic_sweep creature_stack; do
    for mode in semi full hyper; do
        dir="$out/$scene.$mode"
        rm -rf "$dir"
        check=()
        case "$scene" in
        creatures_collide | limb_self_contact | drop_on_pile | kinematic_sweep | creature_stack)
            check=(--check-collisions) ;;
        esac
        frames=12
        [ "$scene" = creature ] && [ "$mode" = full ] && frames=4
        if ! "$run" "$root/samples/$scene/scene.json" -o "$dir" --stats "$dir.stats.json" \
            --frames "$frames" --solver "$mode" --threads 2 "${check[@]}" --log-level warn \
            > "$dir.log" 2>&1; then
            echo "sample_digests: $scene ($mode) failed, see $dir.log" >&2
            status=1
        fi
    done
done
python3 - "$out" > "$out/digest.txt" <<'PY'
import glob, hashlib, json, os, sys
out = sys.argv[1]
TIMING = ('seconds', '_ms', 'ms_', 'rss', 'timings')
def strip(o):
    if isinstance(o, dict):
        return {k: strip(v) for k, v in sorted(o.items()) if not any(t in k for t in TIMING)}
    if isinstance(o, list):
        return [strip(v) for v in o]
    return o
for d in sorted(glob.glob(out + '/*.*')):
    if not os.path.isdir(d):
        continue
    frames = hashlib.sha256()
    for f in sorted(glob.glob(d + '/**/*', recursive=True)):
        if os.path.isfile(f) and not f.endswith('.png') and os.path.basename(f) != 'checkpoint.h5':
            frames.update(f[len(d):].encode())
            frames.update(open(f, 'rb').read())
    stats_file = d + '.stats.json'
    stats = 'nostats'
    if os.path.exists(stats_file):
        text = json.dumps(strip(json.load(open(stats_file))), sort_keys=True)
        stats = hashlib.sha256(text.encode()).hexdigest()[:16]
    print(os.path.basename(d), frames.hexdigest()[:16], stats)
PY
exit "$status"
