#pragma once
// What the solver tests share: the time step, a twisting initial velocity and a stepping loop.

#include <utility>

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"
#include "runtime/state.hpp"

namespace mat::test {

inline constexpr double pd_dt = 1.0 / 60.0;

/// ModelOptions with time step pd_dt and nothing else set.
inline ModelOptions pd_model_options()
{
    ModelOptions options;
    options.time_step = pd_dt;
    return options;
}

/// A twisting and stretching initial velocity field around the x axis through the center
/// of the unit cube: it excites rotation, shear and volume change.  `positions`  n x 3.
inline MatX3 twist_velocities(const MatX3& positions)
{
    MatX3 v(positions.rows(), 3);
    for (Index i = 0; i < positions.rows(); ++i) {
        const Vec3 p = positions.row(i).transpose() - Vec3(0.5, 0.5, 0.5);
        const Vec3 w = Vec3(6.0 * p.x(), 0.0, 0.0);
        v.row(i) = (w.cross(p) + Vec3(0.0, 0.8 * p.x() * p.x(), 0.5 * p.y())).transpose();
    }
    return v;
}

/// `steps` steps of pd_dt from `state`.
inline State run_steps(PdSolver& solver, State state, int steps)
{
    State next;
    for (int s = 0; s < steps; ++s) {
        solver.step(state, next);
        std::swap(state, next);
    }
    return state;
}

} // namespace mat::test
