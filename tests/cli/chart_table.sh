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
echo "chart_table: ok"
