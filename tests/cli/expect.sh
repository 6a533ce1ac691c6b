#!/usr/bin/env bash
# expect.sh CODE PATTERN [--no-file PATH] [--absent PATTERN2] -- COMMAND...
# Runs COMMAND; passes if it exits with CODE and its combined output matches the extended
# regular expression PATTERN (empty: anything). With --no-file, PATH must not exist afterwards
# (no partial output on failure). With --absent, no line of the output may match PATTERN2.
set -u
code="$1"; pattern="$2"; shift 2
no_file=""
absent=""
if [ "${1:-}" = "--no-file" ]; then no_file="$2"; shift 2; fi
if [ "${1:-}" = "--absent" ]; then absent="$2"; shift 2; fi
[ "${1:-}" = "--" ] && shift
out="$("$@" 2>&1)"
got=$?
status=0
if [ "$got" -ne "$code" ]; then
    echo "FAIL: expected exit $code, got $got from: $*"; status=1
fi
if [ -n "$pattern" ] && ! grep -Eq -- "$pattern" <<<"$out"; then
    echo "FAIL: output does not match /$pattern/"; status=1
fi
if [ -n "$absent" ] && grep -Eq -- "$absent" <<<"$out"; then
    echo "FAIL: output matches /$absent/"; status=1
fi
if [ -n "$no_file" ] && [ -e "$no_file" ]; then
    echo "FAIL: $no_file exists after a failed run"; status=1
fi
if [ "$status" -ne 0 ]; then
    echo "---- output ----"; echo "$out"
fi
exit $status
