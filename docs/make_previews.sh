#!/usr/bin/env bash
# make_previews.sh [MAT_RUN]
# Renders the preview pictures of docs/mat-run.md and the README, docs/previews/NAME.png
# (480x360), one per sample: runs each sample scene on its bake for a few frames with
# `mat-run --preview` in a scratch directory and keeps the last frame. A sample whose bake is
# missing (samples/NAME/*.h5: run `make -C samples` first) is skipped with a note.
#   docs/make_previews.sh                        uses build/runtime/mat-run
#   docs/make_previews.sh build-release/runtime/mat-run
#   THREADS=1 docs/make_previews.sh             one thread (default: all)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
run="${1:-$root/build/runtime/mat-run}"
[ -x "$run" ] || { echo "make_previews: no mat-run at $run (build it, or pass its path)" >&2; exit 1; }
out="$root/docs/previews"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
mkdir -p "$out"
# sample:frames (the frame shown: the bodies have moved, landed or met by then)
for entry in capsule:20 rounded_bar:20 torus:20 creature:20 creatures_collide:30 \
    limb_self_contact:30 drop_on_pile:30 kinematic_sweep:30 creature_stack:45 armadillo:20 \
    bunny:20; do
    name="${entry%%:*}"; frames="${entry##*:}"
    scene="$root/samples/$name/scene.json"
    missing=""
    for bake in $(grep -o '"bake": *"[^"]*"' "$scene" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
        [ -f "$root/samples/$name/$bake" ] || missing="$bake"
    done
    if [ -n "$missing" ]; then
        echo "make_previews: $name skipped: no bake $missing (make -C samples $name)"
        continue
    fi
    start=$(date +%s.%N)
    "$run" "$scene" -o "$scratch/$name" --frames "$frames" --preview --preview-size 480x360 \
        --log-level warn ${THREADS:+--threads "$THREADS"} > /dev/null
    cp "$scratch/$name/preview/frame_$(printf %05d "$frames").png" "$out/$name.png"
    echo "make_previews: $out/$name.png ($frames frames, $(awk "BEGIN { printf \"%.1f\", $(date +%s.%N) - $start }") s)"
done
