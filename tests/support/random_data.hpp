#pragma once
// Seeded random data for tests.

#include <random>

#include "common/eigen_types.hpp"

namespace mat::test {

/// `rows x 3` positions uniform in [-1, 1]^3, the same for the same seed.
inline MatX3 random_positions(Index rows, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    MatX3 out(rows, 3);
    for (Index i = 0; i < out.size(); ++i)
        out.data()[i] = u(rng);
    return out;
}

} // namespace mat::test
