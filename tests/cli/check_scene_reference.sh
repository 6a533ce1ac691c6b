#!/usr/bin/env bash
# check_scene_reference.sh MAT_RUN README
# The README's scene reference (between the scene-reference markers) must be exactly what
# `mat-run --scene-reference` prints, so that the documented keys are the parsed ones.
set -euo pipefail
run="$1"; readme="$2"
documented="$(sed -n '/<!-- scene-reference:begin -->/,/<!-- scene-reference:end -->/p' "$readme" | sed '1d;$d')"
generated="$("$run" --scene-reference)"
if [ "$documented" != "$generated" ]; then
    echo "FAIL: the README's scene reference differs from mat-run --scene-reference:"
    diff <(echo "$documented") <(echo "$generated") || true
    echo "(regenerate it: tests/cli/update_scene_reference.sh MAT_RUN README.md)"
    exit 1
fi
