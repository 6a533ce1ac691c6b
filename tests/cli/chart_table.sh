#!/usr/bin/env bash
# speed_accuracy_chart's time-to-accuracy table on a small results file (tests/data/charts): per
# method and RMS target the fastest point that reaches it, "-" where none does, and the fastest
# method per target.
# Usage: chart_table.sh SPEED_ACCURACY_CHART RESULTS.csv WORK_DIR
set -euo pipefail
tool=$1 results=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
"$tool" "$results" "$work" "$work/table.md" > /dev/null
expect_line() {
    grep -qxF "$1" "$work/table.md" || { echo "FAIL: no line '$1' in:"; cat "$work/table.md"; exit 1; }
}
# full space: 1 ms reaches 5% (3%), 2 ms reaches 2% (1.5%), only 50 iterations reach 1% and 0.5%.
expect_line "| full-space PD | 1 ms (5 iterations) | 2 ms (10 iterations) | 9 ms (50 iterations) | 9 ms (50 iterations) |"
# semi: 8 handles (4%) for 5%, 32 handles (1.8%) for 2%, nothing for 1%.
expect_line "| semi-reduced PD (linear) | 0.5 ms (8 handles) | 0.8 ms (32 handles) | - | - |"
expect_line "| **fastest** | **semi-reduced PD (linear)**, 0.5 ms | **semi-reduced PD (linear)**, 0.8 ms | **full-space PD**, 9 ms | **full-space PD**, 9 ms |"
# The Pareto front (RMS against time): every point but full space at 5 iterations (1 ms, 3%),
# which semi-reduced PD with 32 handles beats (0.8 ms, 1.8%); in the table and in both panels.
expect_line "| full-space PD | 5 iterations | 1 | 3 | 6 |  |"
expect_line "| full-space PD | 10 iterations | 2 | 1.5 | 3 | yes |"
expect_line "| semi-reduced PD (linear) | 8 handles | 0.5 | 4 | 8 | yes |"
expect_line "| semi-reduced PD (linear) | 32 handles | 0.8 | 1.8 | 3.5 | yes |"
panels=$(grep -c 'class="pareto"' "$work/bar.svg")
[ "$panels" = 2 ] || { echo "FAIL: $panels Pareto fronts in bar.svg, expected 2"; exit 1; }
# GPU series ("... on the GPU", timed on another machine) stay off the CPU runs' front and fastest
# row: the limb's semi-reduced PD at 1 ms stays on the front and fastest for 5% though its GPU run
# is as accurate in 0.1 ms; the GPU runs have their own fastest row and front (64 handles, slower
# and less accurate than 32, is not on it).
expect_line "| **fastest** | **semi-reduced PD (linear)**, 1 ms | **full-space PD**, 4 ms | **full-space PD**, 4 ms | - |"
expect_line "| **fastest on the GPU** | **semi-reduced PD (linear) on the GPU**, 0.1 ms | **semi-reduced PD (linear) on the GPU**, 0.2 ms | - | - |"
expect_line "| semi-reduced PD (linear) | 8 handles | 1 | 3 | 6 | yes |"
expect_line "| semi-reduced PD (linear) on the GPU | 8 handles | 0.1 | 3 | 6 | GPU front |"
expect_line "| semi-reduced PD (linear) on the GPU | 32 handles | 0.2 | 1.8 | 3.6 | GPU front |"
expect_line "| semi-reduced PD (linear) on the GPU | 64 handles | 0.3 | 2 | 4 |  |"
gpu_rows=$(grep -c '^| \*\*fastest on the GPU\*\*' "$work/table.md")
[ "$gpu_rows" = 1 ] || { echo "FAIL: $gpu_rows 'fastest on the GPU' rows, expected 1 (the limb's)"; exit 1; }
grep -q 'Pareto front of the CPU runs' "$work/limb.svg" || { echo "FAIL: limb.svg's legend does not say its front is the CPU runs'"; exit 1; }
if grep -q 'Pareto front of the CPU runs' "$work/bar.svg"; then echo "FAIL: bar.svg has no GPU series but its legend names CPU runs"; exit 1; fi
echo "chart_table: ok"
