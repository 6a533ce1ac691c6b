#include "runtime/pd/pd_energy.hpp"

#include <algorithm>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

double inertia_energy(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3>& inertia)
{
    const Index n = model.num_nodes();
    MAT_CHECK(positions.rows() == n && inertia.rows() == n,
        "energy: {} positions and {} inertia rows for {} nodes", positions.rows(), inertia.rows(),
        n);
    // Fixed blocks, partial sums added in block order. At most 64 blocks: the partial sums live
    // on the stack (no allocation per call).
    constexpr Index max_blocks = 64;
    const Index per_block = std::max<Index>(1024, (n + max_blocks - 1) / max_blocks);
    const Index blocks = (n + per_block - 1) / per_block;
    double partial[max_blocks] = {};
    const VecX& masses = model.masses();
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, blocks, 1), [&](const tbb::blocked_range<Index>& range) {
            for (Index b = range.begin(); b != range.end(); ++b) {
                double sum = 0.0;
                for (Index i = b * per_block; i < std::min(n, (b + 1) * per_block); ++i)
                    sum += masses(i) * (positions.row(i) - inertia.row(i)).squaredNorm();
                partial[b] = sum;
            }
        });
    double sum = 0.0;
    for (Index b = 0; b < blocks; ++b)
        sum += partial[b];
    const double h = model.time_step();
    return sum / (2.0 * h * h);
}

double pin_energy(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3>& targets)
{
    const std::vector<int>& pins = model.pinned_nodes();
    MAT_CHECK(targets.rows() == static_cast<Index>(pins.size()),
        "energy: {} pin targets for {} pins", targets.rows(), pins.size());
    double sum = 0.0;
    for (std::size_t p = 0; p < pins.size(); ++p)
        sum += (positions.row(pins[p]) - targets.row(static_cast<Index>(p))).squaredNorm();
    return 0.5 * model.pin_weight() * sum;
}

} // namespace mat
