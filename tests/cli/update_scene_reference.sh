#!/usr/bin/env bash
# update_scene_reference.sh MAT_RUN README: rewrites the README's scene reference from
# `mat-run --scene-reference` (run it after changing the scene schema).
set -euo pipefail
run="$1"; readme="$2"
ref="$(mktemp)"; out="$(mktemp)"
"$run" --scene-reference > "$ref"
awk -v ref="$ref" '
    /<!-- scene-reference:begin -->/ { print; while ((getline line < ref) > 0) print line; skip = 1; next }
    /<!-- scene-reference:end -->/ { skip = 0 }
    !skip { print }' "$readme" > "$out"
mv "$out" "$readme"
rm -f "$ref"
