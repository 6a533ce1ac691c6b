#include "runtime/pd/angular_momentum.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Dense>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

namespace {

    // Fixed blocks whose partial sums are added in block order (as in pd_energy.cpp): at most 64,
    // on the stack.
    constexpr Index max_blocks = 64;

    struct Blocks {
        Index per_block;
        Index count;
        Index begin(Index b) const { return b * per_block; }
        Index end(Index b, Index n) const { return std::min(n, (b + 1) * per_block); }
    };

    Blocks blocks_of(Index n)
    {
        const Index per_block = std::max<Index>(1024, (n + max_blocks - 1) / max_blocks);
        return { per_block, (n + per_block - 1) / per_block };
    }

    /// Sums over the blocks of `per_block`(b) -> std::array<double, K>, added in block order.
    template <std::size_t K, class PerBlock>
    std::array<double, K> block_sums(const Blocks& blocks, const PerBlock& per_block)
    {
        std::array<std::array<double, K>, max_blocks> partial {};
        tbb::parallel_for(tbb::blocked_range<Index>(0, blocks.count, 1),
            [&](const tbb::blocked_range<Index>& range) {
                for (Index b = range.begin(); b != range.end(); ++b)
                    partial[static_cast<std::size_t>(b)] = per_block(b);
            });
        std::array<double, K> total {};
        for (Index b = 0; b < blocks.count; ++b)
            for (std::size_t k = 0; k < K; ++k)
                total[k] += partial[static_cast<std::size_t>(b)][k];
        return total;
    }

} // namespace

double AngularMomentumKeeper::apply(const VecX& masses,
    const Eigen::Ref<const MatX3>& start_positions, const Eigen::Ref<const MatX3>& start_velocities,
    const Eigen::Ref<const MatX3>& end_positions, double h, const Vec3& impulse, const Vec3& moment,
    double velocity_scale, Eigen::Ref<MatX3> end_velocities) const
{
    const Index n = masses.size();
    MAT_CHECK(start_positions.rows() == n && start_velocities.rows() == n
            && end_positions.rows() == n && end_velocities.rows() == n,
        "angular momentum: state rows differ from the {} masses", n);
    if (n == 0 || !(h > 0.0))
        return 0.0;
    const Blocks blocks = blocks_of(n);
    // Mass and the first moments at the start and at the end.
    const std::array<double, 7> first = block_sums<7>(blocks, [&](Index b) {
        double mass = 0.0;
        Vec3 start = Vec3::Zero();
        Vec3 end = Vec3::Zero();
        for (Index i = blocks.begin(b); i < blocks.end(b, n); ++i) {
            mass += masses(i);
            start += masses(i) * start_positions.row(i).transpose();
            end += masses(i) * end_positions.row(i).transpose();
        }
        return std::array<double, 7> { mass, start.x(), start.y(), start.z(), end.x(), end.y(),
            end.z() };
    });
    const double mass = first[0];
    if (!(mass > 0.0))
        return 0.0;
    const Vec3 c0 = Vec3(first[1], first[2], first[3]) / mass;
    const Vec3 c1 = Vec3(first[4], first[5], first[6]) / mass;
    // About c0 (near the body, against cancellation): the angular momenta at the start and at the
    // end, and the inertia tensor about c1 (xx, yy, zz, xy, xz, yz).
    const std::array<double, 12> second = block_sums<12>(blocks, [&](Index b) {
        Vec3 l0 = Vec3::Zero();
        Vec3 l1 = Vec3::Zero();
        std::array<double, 6> inertia {};
        for (Index i = blocks.begin(b); i < blocks.end(b, n); ++i) {
            const double m = masses(i);
            const Vec3 x0 = start_positions.row(i).transpose() - c0;
            const Vec3 x1 = end_positions.row(i).transpose();
            const Vec3 u = (x1 - start_positions.row(i).transpose()) / h;
            l0 += m * x0.cross(start_velocities.row(i).transpose());
            l1 += m * (x1 - c0).cross(u);
            const Vec3 r = x1 - c1;
            inertia[0] += m * (r.y() * r.y() + r.z() * r.z());
            inertia[1] += m * (r.x() * r.x() + r.z() * r.z());
            inertia[2] += m * (r.x() * r.x() + r.y() * r.y());
            inertia[3] -= m * r.x() * r.y();
            inertia[4] -= m * r.x() * r.z();
            inertia[5] -= m * r.y() * r.z();
        }
        return std::array<double, 12> { l0.x(), l0.y(), l0.z(), l1.x(), l1.y(), l1.z(), inertia[0],
            inertia[1], inertia[2], inertia[3], inertia[4], inertia[5] };
    });
    // Gravity's moment about c0 at x_n is zero; the contacts' is moment - c0 x impulse.
    const Vec3 target = Vec3(second[0], second[1], second[2]) + moment - c0.cross(impulse);
    const Vec3 change = target - Vec3(second[3], second[4], second[5]);
    Eigen::Matrix3d inertia;
    inertia << second[6], second[9], second[10], second[9], second[7], second[11], second[10],
        second[11], second[8];
    // A body whose nodes lie on a line has no inertia about it: it is left as it is.
    const Eigen::LDLT<Eigen::Matrix3d> factor(inertia);
    if (factor.info() != Eigen::Success || !(factor.vectorD().minCoeff() > 1e-12 * inertia.trace()))
        return 0.0;
    const Vec3 omega = factor.solve(change);
    const Eigen::RowVector3d w = (velocity_scale * omega).transpose();
    const Eigen::RowVector3d c = c1.transpose();
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            end_velocities.row(i) += w.cross(end_positions.row(i) - c);
    });
    return change.norm();
}

} // namespace mat
