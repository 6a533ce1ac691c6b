#!/usr/bin/env bash
# README command 2 (and what .ci/run calls): install dependencies, build, run the whole test
# suite. Extra arguments go to cmake's configure step, e.g. -DMAT_SANITIZE=ON.
# BUILD_DIR picks the build directory (default: build).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
bash "$root/.ci/install-deps.sh"
start=$(date +%s)
mkdir -p "$build"
cmake -S "$root" -B "$build" "$@" > "$build/configure.log" 2>&1 || { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j"$(nproc)"
built=$(date +%s)
ctest --test-dir "$build" --output-on-failure -j"$(nproc)" --timeout 900
done_at=$(date +%s)
echo "tests/run.sh: build $((built - start)) s, tests $((done_at - built)) s"
