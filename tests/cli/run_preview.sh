#!/usr/bin/env bash
# run_preview.sh MAT_RUN SCENE BAKE WORK_DIR FRAMES FPS
# Runs a scene (copied into WORK_DIR next to BAKE, which must have the file name the scene
# names) for a few frames with --preview (small images) and checks that every frame's PNG
# is there, starts with the PNG signature, is not trivially small, and that no temporary is left.
# Without a real ffmpeg on PATH, a stand-in records its arguments and writes the movie file, to
# check that preview.mp4 is assembled at the scene's frame rate (FPS, the 6th argument).
set -euo pipefail
run="$1"; scene="$2"; bake="$3"; work="$4"; frames="$5"; fps="$6"
rm -rf "$work"; mkdir -p "$work"
cp "$scene" "$work/scene.json"
cp "$bake" "$work/$(basename "$bake")"
scene="$work/scene.json"
fake=0
if ! command -v ffmpeg >/dev/null; then
    fake=1
    mkdir -p "$work/bin"
    printf '#!/bin/sh\necho "$@" > "%s"\nfor last; do :; done\necho fake > "$last"\n' \
        "$work/ffmpeg_args" > "$work/bin/ffmpeg"
    chmod +x "$work/bin/ffmpeg"
    export PATH="$work/bin:$PATH"
fi
"$run" "$scene" -o "$work/out" --frames "$frames" --preview --preview-size 160x120 --threads 1
status=0
for ((f = 0; f <= frames; ++f)); do
    png="$work/out/preview/frame_$(printf %05d "$f").png"
    if [ ! -f "$png" ]; then echo "FAIL: no $png"; status=1; continue; fi
    signature=$(head -c 8 "$png" | od -An -tx1 | tr -d ' \n')
    [ "$signature" = "89504e470d0a1a0a" ] || { echo "FAIL: $png: signature $signature"; status=1; }
    size=$(stat -c %s "$png")
    [ "$size" -gt 2000 ] || { echo "FAIL: $png: only $size bytes"; status=1; }
done
count=$(ls "$work/out/preview" | grep -c '^frame_[0-9]*\.png$' || true)
[ "$count" -eq $((frames + 1)) ] || { echo "FAIL: $count preview frames, expected $((frames + 1))"; status=1; }
ls -A "$work/out" "$work/out/preview" | grep -q '\.tmp' && { echo "FAIL: temporary files left"; status=1; }
[ -s "$work/out/preview.mp4" ] || { echo "FAIL: no preview.mp4"; status=1; }
if [ $fake -eq 1 ] && ! grep -q -- "-framerate $fps " "$work/ffmpeg_args"; then
    echo "FAIL: ffmpeg not run at $fps frames per second: $(cat "$work/ffmpeg_args")"; status=1
fi
[ $status -eq 0 ] && echo "preview: $count frames ok"
exit $status
