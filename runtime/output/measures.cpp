#include "runtime/output/measures.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "runtime/pd/local_step.hpp"

namespace mat {

BodyMeasures measure_body(
    const Model& model, const State& state, const Vec3& gravity, VecX* tet_strain)
{
    BodyMeasures result;
    const VecX& masses = model.masses();
    for (Index i = 0; i < model.num_nodes(); ++i) {
        result.kinetic += 0.5 * masses(i) * state.velocities.row(i).squaredNorm();
        result.potential -= masses(i) * gravity.dot(state.positions.row(i).transpose());
    }
    const Index t = model.num_tets();
    VecX energy(t), strain(t);
    const double mu = 0.5 * model.strain_weight(); // w_strain = 2 mu
    const double lambda = model.volume_weight();
    const double limit = model.strain_limit_weight();
    tbb::parallel_for(tbb::blocked_range<Index>(0, t), [&](const tbb::blocked_range<Index>& range) {
        for (Index e = range.begin(); e != range.end(); ++e) {
            const Mat3 f
                = deformation_gradient(state.positions, model.tets(), model.dm_inverse(), e);
            const TetProjection p = project_tet(f, model.volume_tolerance(),
                model.material().strain_limit_min, model.material().strain_limit_max);
            const Mat3 d = f - p.rotation;
            energy(e) = model.rest_volumes()(e)
                * (mu * d.squaredNorm() + 0.5 * lambda * (f - p.volume).squaredNorm()
                    + 0.5 * limit * (f - p.limit).squaredNorm());
            // F - R = U (S - I) V^T: its spectral norm is max |sigma_i - 1|.
            Eigen::SelfAdjointEigenSolver<Mat3> eigen;
            eigen.computeDirect(d.transpose() * d, Eigen::EigenvaluesOnly);
            strain(e) = std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
        }
    });
    result.elastic = energy.sum();
    result.max_strain = t > 0 ? strain.maxCoeff() : 0.0;
    if (tet_strain)
        *tet_strain = std::move(strain);
    return result;
}

} // namespace mat
