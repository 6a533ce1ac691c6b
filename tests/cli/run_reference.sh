#!/usr/bin/env bash
# run_reference.sh MAT_RUN SCENE BAKE WORK_DIR FRAMES
# mat-run --reference on a sample scene (output obj only, so the run must add its own
# trajectory.h5): a full-space run is the reference; the same run against it has error 0; the
# semi-reduced run has a positive error, printed and in --stats; a reference with another frame
# count is refused (exit 1, one line, no output directory).
set -euo pipefail
run="$1"; scene="$2"; bake="$3"; work="$4"; frames="$5"
rm -rf "$work"; mkdir -p "$work"
sed -e 's/"output": *{[^}]*}/"output": { "format": "obj", "every": 1 }/' "$scene" > "$work/scene.json"
for b in $(grep -o '"bake": *"[^"]*"' "$work/scene.json" | sed 's/.*"\([^"]*\)"$/\1/' | sort -u); do
    cp "$bake" "$work/$b"
done
status=0
fail() { echo "FAIL: $*"; status=1; }
"$run" "$work/scene.json" -o "$work/ref" --frames "$frames" --solver full --threads 2 >/dev/null
[ -s "$work/ref/trajectory.h5" ] && fail "the reference run wrote trajectory.h5 without h5 output"
# The reference is written with h5 output (a copy of the scene with h5 added).
sed -e 's/"format": "obj"/"format": ["obj", "h5"]/' "$work/scene.json" > "$work/scene_h5.json"
"$run" "$work/scene_h5.json" -o "$work/ref" --frames "$frames" --solver full --threads 2 >/dev/null
[ -s "$work/ref/trajectory.h5" ] || fail "no reference trajectory.h5"

out="$("$run" "$work/scene.json" -o "$work/same" --frames "$frames" --solver full --threads 2 \
    --reference "$work/ref/trajectory.h5" --stats "$work/same.json")"
grep -q 'reference error .*RMS 0%, max 0%' <<<"$out" || fail "full against itself: $out"
[ -s "$work/same/trajectory.h5" ] || fail "--reference did not write trajectory.h5"
grep -q '"reference_error"' "$work/same.json" || fail "no reference_error in --stats"
grep -Eq '"max_percent": 0(\.0)?,?$' "$work/same.json" || fail "max_percent is not 0 in --stats"

out="$("$run" "$work/scene.json" -o "$work/semi" --frames "$frames" --threads 2 \
    --reference "$work/ref/trajectory.h5" --stats "$work/semi.json")"
grep -Eq 'reference error .*RMS [0-9.e-]+%, max [0-9.e-]+%' <<<"$out" || fail "semi: $out"
grep -q 'RMS 0%' <<<"$out" && fail "semi-reduced has zero error against full-space: $out"
grep -Eq '"rms_percent": [0-9]' "$work/semi.json" || fail "no rms_percent in --stats"

set +e
out="$("$run" "$work/scene.json" -o "$work/bad" --frames $((frames + 1)) \
    --reference "$work/ref/trajectory.h5" 2>&1)"
code=$?
set -e
[ "$code" -eq 1 ] || fail "frame mismatch: exit $code, expected 1"
grep -q "trajectory.h5: the reference has $((frames + 1)) frames, this run writes $((frames + 2))" \
    <<<"$out" || fail "frame mismatch message: $out"
[ -e "$work/bad" ] && fail "a refused run left $work/bad"
exit $status
