#!/usr/bin/env bash
# Builds the libFuzzer targets (clang) and fuzzes each for MINUTES from its seed corpus, one
# target at a time (docs/building.md, Fuzzing).
#   tests/fuzz/run_fuzzers.sh MINUTES [TARGET...]      (no TARGET: every target)
# Per target it prints minutes, executions, crashes and hangs, and copies every crash, timeout,
# out-of-memory or leak input into tests/fuzz/regressions/<target>/ (the default test run feeds
# those files back through the same target, built without libFuzzer).
# Environment: MAT_FUZZ_BUILD (build folder, default build-fuzz), MAT_FUZZ_JOBS (build jobs,
# default 2), MAT_FUZZ_NICE (nice level, default 10), MAT_FUZZ_ARGS (extra libFuzzer flags),
# MAT_FUZZ_SKIP_BUILD=1 (fuzz the executables already built).
set -euo pipefail

all_targets=(fuzz_medial_reader fuzz_tet_mesh_reader fuzz_surface_reader fuzz_scene_parser
    fuzz_bake_structured fuzz_bake_raw fuzz_trajectory_structured fuzz_trajectory_raw
    fuzz_checkpoint_structured)

if [[ $# -lt 1 || ! $1 =~ ^[0-9]+([.][0-9]+)?$ ]]; then
    echo "usage: $0 MINUTES [TARGET...]   targets: ${all_targets[*]}" >&2
    exit 2
fi
minutes=$1
shift
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=("${all_targets[@]}")
for target in "${targets[@]}"; do
    if [[ ! " ${all_targets[*]} " =~ " ${target} " ]]; then
        echo "$0: unknown target '$target' (targets: ${all_targets[*]})" >&2
        exit 2
    fi
done

root=$(cd "$(dirname "$0")/../.." && pwd)
build=${MAT_FUZZ_BUILD:-$root/build-fuzz}
jobs=${MAT_FUZZ_JOBS:-2}
niceness=${MAT_FUZZ_NICE:-10}
seconds=$(awk -v m="$minutes" 'BEGIN { printf "%d", m * 60 }')

launcher=()
if command -v ccache > /dev/null; then
    launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
if [[ ${MAT_FUZZ_SKIP_BUILD:-0} != 1 ]]; then
    cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMAT_BUILD_FUZZERS=ON \
        -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 "${launcher[@]}" > /dev/null
    nice -n "$niceness" cmake --build "$build" -j "$jobs" --target "${targets[@]}"
fi

summary=()
failed=0
for target in "${targets[@]}"; do
    work=$build/fuzz-work/$target
    seeds=$root/tests/fuzz/corpus/$target
    kept=$root/tests/fuzz/regressions/$target
    rm -rf "$work"
    mkdir -p "$work/corpus" "$work/artifacts" "$kept"
    # libFuzzer adds what it finds to the first folder; the seeds and regressions stay as they are.
    inputs=("$work/corpus" "$seeds")
    [[ -n $(ls -A "$kept") ]] && inputs+=("$kept")
    command=(env LSAN_OPTIONS="suppressions=$root/tests/fuzz/lsan_suppressions.txt:print_suppressions=0"
        nice -n "$niceness" "$build/tests/fuzz/$target" -max_total_time="$seconds"
        -timeout=10 -rss_limit_mb=2048 -print_final_stats=1
        -artifact_prefix="$work/artifacts/" ${MAT_FUZZ_ARGS:-} "${inputs[@]}")
    echo "== $target: ${command[*]}"
    start=$(date +%s)
    status=0
    "${command[@]}" > "$work/log.txt" 2>&1 || status=$?
    elapsed=$(($(date +%s) - start))
    executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log.txt" | tail -n 1)
    if [[ -z $executions ]]; then # -fork mode prints no final stats: its last status line
        executions=$(sed -n 's/^#\([0-9][0-9]*\)[:\t ].*/\1/p' "$work/log.txt" | tail -n 1)
    fi
    crashes=0
    hangs=0
    for artifact in "$work"/artifacts/*; do
        [[ -e $artifact ]] || continue
        case $(basename "$artifact") in
        timeout-*) hangs=$((hangs + 1)) ;;
        *) crashes=$((crashes + 1)) ;;
        esac
        cp "$artifact" "$kept/"
    done
    if [[ $status -ne 0 && $crashes -eq 0 && $hangs -eq 0 ]]; then
        crashes=1 # a failure that left no artifact (e.g. the fuzzer itself died): see the log
    fi
    [[ $crashes -eq 0 && $hangs -eq 0 ]] || failed=1
    line=$(printf '%-28s minutes %5.1f  executions %10s  crashes %d  hangs %d  (log %s)' \
        "$target" "$(awk -v s="$elapsed" 'BEGIN { print s / 60 }')" "${executions:-?}" \
        "$crashes" "$hangs" "$work/log.txt")
    echo "$line"
    summary+=("$line")
    if [[ $crashes -ne 0 || $hangs -ne 0 ]]; then
        grep -m 20 -E 'ERROR|SUMMARY|invariant|==[0-9]+==|#[0-9]+ 0x' "$work/log.txt" || true
    fi
done

echo "== summary (${minutes} minutes per target)"
printf '%s\n' "${summary[@]}"
exit $failed
