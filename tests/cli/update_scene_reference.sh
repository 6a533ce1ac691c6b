#!/usr/bin/env bash
# update_scene_reference.sh MAT_RUN DOC: rewrites the scene reference in DOC (docs/scenes.md,
# between the scene-reference markers) from `mat-run --scene-reference` (run it after changing
# the scene schema).
set -euo pipefail
run="$1"; doc="$2"
ref="$(mktemp)"; out="$(mktemp)"
"$run" --scene-reference > "$ref"
awk -v ref="$ref" '
    /<!-- scene-reference:begin -->/ { print; while ((getline line < ref) > 0) print line; skip = 1; next }
    /<!-- scene-reference:end -->/ { skip = 0 }
    !skip { print }' "$doc" > "$out"
mv "$out" "$doc"
rm -f "$ref"
