#pragma once
// Golden-section search, for brute-force references in tests.

#include <algorithm>
#include <cmath>

namespace mat::test {

/// Minimum of a unimodal (e.g. convex) function f over [lo, hi] after `iterations` shrinks.
template <typename F> double golden_section_min(F f, double lo, double hi, int iterations)
{
    const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
    double x1 = hi - ratio * (hi - lo), x2 = lo + ratio * (hi - lo);
    double f1 = f(x1), f2 = f(x2);
    for (int k = 0; k < iterations; ++k) {
        if (f1 <= f2) {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - ratio * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + ratio * (hi - lo);
            f2 = f(x2);
        }
    }
    return std::min({ f1, f2, f(lo), f(hi) });
}

} // namespace mat::test
