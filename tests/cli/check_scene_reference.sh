#!/usr/bin/env bash
# check_scene_reference.sh MAT_RUN DOC
# The scene reference in DOC (docs/scenes.md, between the scene-reference markers) must be exactly
# what `mat-run --scene-reference` prints, so that the documented keys are the parsed ones.
set -euo pipefail
run="$1"; doc="$2"
documented="$(sed -n '/<!-- scene-reference:begin -->/,/<!-- scene-reference:end -->/p' "$doc" | sed '1d;$d')"
generated="$("$run" --scene-reference)"
if [ "$documented" != "$generated" ]; then
    echo "FAIL: the scene reference in $doc differs from mat-run --scene-reference:"
    diff <(echo "$documented") <(echo "$generated") || true
    echo "(regenerate it: tests/cli/update_scene_reference.sh MAT_RUN docs/scenes.md)"
    exit 1
fi
