#!/usr/bin/env bash
# same_refusal.sh MAT_BAKE OUT PATTERN SURFACE [OPTIONS...]
# `mat-bake check SURFACE [--medial FILE]` and the bake `mat-bake SURFACE OPTIONS... -o OUT` must
# refuse the same input with the same line: both exit 1, both error lines are identical and match
# the extended regular expression PATTERN, and OUT does not exist afterwards. Of OPTIONS, check
# is given only --medial FILE and --allow-self-intersections.
set -u
bake="$1"; out="$2"; pattern="$3"; surface="$4"; shift 4
check_options=()
options=("$@")
while [ $# -gt 0 ]; do
    case "$1" in
        --medial) check_options+=("$1" "$2"); shift 2 ;;
        --allow-self-intersections) check_options+=("$1"); shift ;;
        *) shift ;;
    esac
done
rm -f "$out"
check_output="$("$bake" check "$surface" "${check_options[@]}" 2>&1)"; check_code=$?
bake_output="$("$bake" "$surface" "${options[@]}" -o "$out" 2>&1)"; bake_code=$?
check_line="$(grep -m1 'error:' <<<"$check_output")"
bake_line="$(grep -m1 'error:' <<<"$bake_output")"
status=0
[ "$check_code" -eq 1 ] || { echo "FAIL: check exited $check_code, expected 1"; status=1; }
[ "$bake_code" -eq 1 ] || { echo "FAIL: the bake exited $bake_code, expected 1"; status=1; }
[ "$check_line" = "$bake_line" ] || { echo "FAIL: the refusals differ"; status=1; }
grep -Eq -- "$pattern" <<<"$bake_line" || { echo "FAIL: no /$pattern/ in the bake's line"; status=1; }
[ ! -e "$out" ] || { echo "FAIL: $out exists after a refused bake"; status=1; }
if [ "$status" -ne 0 ]; then
    printf -- "---- check ----\n%s\n---- bake ----\n%s\n" "$check_output" "$bake_output"
fi
exit $status
