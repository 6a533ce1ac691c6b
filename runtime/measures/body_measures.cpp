#include "runtime/measures/body_measures.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "runtime/pd/elastic_term.hpp"
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
        result.momentum += masses(i) * state.velocities.row(i).transpose();
    }
    const Index t = model.num_tets();
    VecX energy(t), strain(t);
    const double mu = 0.5 * model.strain_weight(); // w_strain = 2 mu
    const double lambda = model.volume_weight();
    const double limit = model.strain_limit_weight();
    // The three projections separately (unit weights), 16 tets at a time with the local step's
    // vectorized kernel in its exact mode.
    ProjectionParams params[3];
    for (ProjectionParams& p : params) {
        p.volume_tolerance = model.volume_tolerance();
        p.limit_min = model.material().strain_limit_min;
        p.limit_max = model.material().strain_limit_max;
        p.rotation_weight = 0.0;
        p.exact = true;
    }
    params[0].rotation_weight = 1.0;
    params[1].volume_weight = 1.0;
    params[2].limit_weight = 1.0;
    const double weights[3] = { mu, 0.5 * lambda, 0.5 * limit };
    constexpr int lanes = projection_lanes;
    const Index blocks = (t + lanes - 1) / lanes;
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, blocks), [&](const tbb::blocked_range<Index>& range) {
            MatBlock f, target;
            Mat3 fs[lanes];
            for (Index b = range.begin(); b != range.end(); ++b) {
                const Index first = b * lanes;
                const int count = static_cast<int>(std::min<Index>(lanes, t - first));
                for (int l = 0; l < lanes; ++l) {
                    fs[l] = deformation_gradient(state.positions, model.tets(), model.dm_inverse(),
                        first + (l < count ? l : 0));
                    for (int i = 0; i < 9; ++i)
                        f.m[i][l] = fs[l](i / 3, i % 3);
                }
                double sums[lanes] = {};
                Mat3 rotation[lanes];
                for (int k = 0; k < 3; ++k) {
                    if (weights[k] == 0.0 && k > 0)
                        continue;
                    RotationBlock warm;
                    project_elastic_block(f, params[k], target, warm);
                    for (int l = 0; l < count; ++l) {
                        Mat3 p;
                        for (int i = 0; i < 9; ++i)
                            p(i / 3, i % 3) = target.m[i][l];
                        sums[l] += weights[k] * (fs[l] - p).squaredNorm();
                        if (k == 0)
                            rotation[l] = p;
                    }
                }
                for (int l = 0; l < count; ++l) {
                    const Index e = first + l;
                    energy(e) = model.rest_volumes()(e) * sums[l];
                    // F - R = U (S - I) V^T: its spectral norm is max |sigma_i - 1|.
                    const Mat3 d = fs[l] - rotation[l];
                    Eigen::SelfAdjointEigenSolver<Mat3> eigen;
                    eigen.computeDirect(d.transpose() * d, Eigen::EigenvaluesOnly);
                    strain(e) = std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
                }
            }
        });
    result.elastic = energy.sum();
    result.max_strain = t > 0 ? strain.maxCoeff() : 0.0;
    if (tet_strain)
        *tet_strain = std::move(strain);
    return result;
}

} // namespace mat
