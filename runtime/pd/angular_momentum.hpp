#pragma once
// The angular momentum a body's internal forces add (docs/method.md, "Angular momentum"), and
// its removal.
//
// Internal forces exert no net moment on a body: its angular momentum changes only by the
// moments of the forces from outside (gravity, pins, contacts). The step does not keep this.
// Implicit Euler takes every force's moment at the start-of-step positions x_n: over a step
// from (x_n, v_n) to x_{n+1}, with u = (x_{n+1} - x_n) / h and any forces, exactly
//   L(x_{n+1}, u) - L(x_n, v_n) = sum_i x_{n,i} x m_i (u_i - v_{n,i}),
// and the elastic forces, evaluated at x_{n+1} where they have no moment, have one of
// -h^2 sum_i u_i x f_el,i at x_n. Under spin and vibration that takes a few percent of a body's
// angular momentum per second at dt = 1/60 s, and a smaller step does not cure it (it also damps
// the vibration less). Unconverged iterations (the elastic forces then have a moment at x_{n+1}
// too) and the hyper-reduced fit add more, most of all in an impact.
//
// AngularMomentumKeeper sets the body's angular momentum at the end of the step to its start
// value plus the moments, at x_n, of the step's external impulses: gravity's (none about the
// centre of mass) and the contacts' the caller gives. It adds to u the rigid rotation about the
// body's centre of mass, w x (x_{n+1} - c), with I w the difference (I: the inertia tensor about
// c at x_{n+1}); that adds no linear momentum, leaves the positions as they are and lies in the
// handle basis (which holds the rotations of the current positions). A contact's two points are
// a closest-point pair along its force at x_n, so two bodies in contact keep their summed
// angular momentum. Sums run in fixed blocks added in order: the same result for any thread
// count; no allocation.
//
// Which bodies the solver gives it to (SolverOptions::angular_momentum): "free" gives it only
// to a body without pins or contact candidates in the step. With contacts that hold a body, the
// contact forces are solved against the step's own response, elastic moment included, and a
// rotation added after them fights them: a capsule resting on the ground rocked from step to
// step, and a crib of stiff bars (E = 1e6 Pa) resting on each other went from 1418 to 15050 J.
// "keep" (the default) gives it also to a body in contact whose contact island (the stepped
// bodies that pushed each other in the step, transitively) has no body with pins or pushed by
// the world (StepReport::world_held): impacts between free bodies then keep their angular
// momentum, and a pile on the ground, one island held by the ground, settles as without it.
// Hyper-reduced impacts sink about a fifth deeper with it than with "free" (docs/method.md,
// "Angular momentum").

#include "common/eigen_types.hpp"

namespace mat {

class AngularMomentumKeeper {
public:
    /// `masses` n, `start_positions`, `start_velocities`, `end_positions`  n x 3, `h` the step;
    /// `impulse` and `moment`: the sum over the external impulses h f_k at nodes k other than
    /// gravity's (contacts) of h f_k (N s) and of x_{n,k} x h f_k (about the origin,
    /// kg m^2/s). `end_velocities` = `velocity_scale` u on entry (the solver's damped
    /// velocities), and `velocity_scale` (u + w x (x_{n+1} - c)) on return. Returns |I w|, the
    /// angular momentum (kg m^2/s) that the step's internal forces had added or removed.
    double apply(const VecX& masses, const Eigen::Ref<const MatX3>& start_positions,
        const Eigen::Ref<const MatX3>& start_velocities,
        const Eigen::Ref<const MatX3>& end_positions, double h, const Vec3& impulse,
        const Vec3& moment, double velocity_scale, Eigen::Ref<MatX3> end_velocities) const;
};

} // namespace mat
