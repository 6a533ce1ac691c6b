#include "preprocess/meshing/zero_set_projection.hpp"

#include <cmath>

#include <tbb/parallel_for.h>

namespace mat {

MatX3 project_onto_zero_set(const Eigen::Ref<const MatX3>& points,
    const std::function<double(const Vec3&)>& f, int steps, double max_step)
{
    MatX3 result = points;
    if (steps <= 0 || points.rows() == 0)
        return result;
    // The finite-difference step: small against the feature size, large against rounding.
    const double h = 1e-4 * max_step;
    tbb::parallel_for(Index(0), points.rows(), [&](Index i) {
        Vec3 x = result.row(i).transpose();
        double value = f(x);
        for (int step = 0; step < steps && value != 0.0; ++step) {
            Vec3 gradient;
            for (int axis = 0; axis < 3; ++axis) {
                Vec3 forward = x, backward = x;
                forward(axis) += h;
                backward(axis) -= h;
                gradient(axis) = (f(forward) - f(backward)) / (2.0 * h);
            }
            const double squared_norm = gradient.squaredNorm();
            if (!(squared_norm > 0.0) || !std::isfinite(squared_norm))
                break;
            Vec3 delta = -value / squared_norm * gradient;
            const double length = delta.norm();
            if (length > max_step)
                delta *= max_step / length;
            const Vec3 candidate = x + delta;
            const double candidate_value = f(candidate);
            if (!(std::abs(candidate_value) < std::abs(value)))
                break;
            x = candidate;
            value = candidate_value;
        }
        result.row(i) = x.transpose();
    });
    return result;
}

} // namespace mat
