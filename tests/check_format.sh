#!/usr/bin/env bash
# check_format.sh CLANG_FORMAT: fails, listing the files, if any C++ source differs from
# .clang-format. Fix with: clang-format -i $(git ls-files '*.cpp' '*.hpp' '*.cu')
set -euo pipefail
clang_format="$1"
mapfile -t files < <(find common formats preprocess runtime tests -name '*.cpp' -o -name '*.hpp' -o -name '*.cu' | sort)
bad=()
for f in "${files[@]}"; do
    if ! "$clang_format" --dry-run --Werror "$f" >/dev/null 2>&1; then bad+=("$f"); fi
done
if [ "${#bad[@]}" -gt 0 ]; then
    echo "clang-format: ${#bad[@]} file(s) need formatting: ${bad[*]}"
    exit 1
fi
echo "clang-format: ${#files[@]} files clean"
