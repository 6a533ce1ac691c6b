#!/usr/bin/env bash
# check_samples.sh MAT_BAKE SAMPLES_DIR OUT_DIR
# The committed samples are what the generator makes: regenerate every sample into OUT_DIR and
# compare byte for byte with SAMPLES_DIR/NAME/NAME.{obj,ma}.
set -euo pipefail
bake="$1"; samples="$2"; out="$3"
rm -rf "$out"; mkdir -p "$out"
"$bake" --log-level warn sample all -o "$out" > /dev/null
status=0
for dir in "$out"/*/; do
    name="$(basename "$dir")"
    for ext in obj ma; do
        if ! cmp -s "$dir/$name.$ext" "$samples/$name/$name.$ext"; then
            echo "FAIL: samples/$name/$name.$ext differs from what 'mat-bake sample $name' makes"
            status=1
        fi
    done
done
[ "$status" -eq 0 ] && echo "samples: $(ls "$out" | wc -l) samples regenerate identically"
exit $status
