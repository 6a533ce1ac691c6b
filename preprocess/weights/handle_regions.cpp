#include "preprocess/weights/handle_regions.hpp"

#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

VecXi assign_handle_regions(const Eigen::Ref<const MatX3>& rest_positions,
    const Eigen::Ref<const MatX3>& centers, const Eigen::Ref<const VecX>& radii, double alpha)
{
    const Index n = rest_positions.rows();
    const Index m = centers.rows();
    MAT_CHECK(radii.size() == m, "{} radii for {} handle centers", radii.size(), m);
    if (!(alpha > 0.0) || !std::isfinite(alpha))
        throw_error("handle regions: alpha must be > 0, got {}", alpha);
    if (m > n)
        throw_error("handle regions: {} handles but only {} tet-mesh nodes", m, n);
    for (Index j = 0; j < m; ++j)
        if (!(radii[j] > 0.0) || !std::isfinite(radii[j]) || !centers.row(j).allFinite())
            throw_error(
                "handle regions: handle {} has radius {} (must be finite and > 0)", j, radii[j]);

    // Steps 1-2: each node picks, among the balls containing it, the smallest relative distance.
    VecXi owner = VecXi::Constant(n, -1);
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, n, 256), [&](const tbb::blocked_range<Index>& range) {
            for (Index i = range.begin(); i < range.end(); ++i) {
                double best = std::numeric_limits<double>::infinity();
                for (Index j = 0; j < m; ++j) {
                    const double relative
                        = (rest_positions.row(i) - centers.row(j)).norm() / radii[j];
                    if (relative <= alpha && relative < best) {
                        best = relative;
                        owner[i] = static_cast<int>(j);
                    }
                }
            }
        });

    // Step 3: empty handles, in index order, take their nearest node unless it is the only node
    // of another region. One always exists: m <= #V, so if every node is owned some region
    // has two.
    VecXi count = VecXi::Zero(m);
    for (Index i = 0; i < n; ++i)
        if (owner[i] >= 0)
            ++count[owner[i]];
    for (Index j = 0; j < m; ++j) {
        if (count[j] > 0)
            continue;
        Index nearest = -1;
        double best = std::numeric_limits<double>::infinity();
        for (Index i = 0; i < n; ++i) {
            if (owner[i] >= 0 && count[owner[i]] < 2)
                continue;
            const double distance = (rest_positions.row(i) - centers.row(j)).squaredNorm();
            if (distance < best) {
                best = distance;
                nearest = i;
            }
        }
        MAT_CHECK(nearest >= 0, "no node left for handle {}", j);
        if (owner[nearest] >= 0)
            --count[owner[nearest]];
        owner[nearest] = static_cast<int>(j);
        count[j] = 1;
    }
    return owner;
}

} // namespace mat
