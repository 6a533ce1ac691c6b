#pragma once
// Implicit Euler projective dynamics (Bouaziz et al. 2014; semi-reduced as in Lan et al. 2020,
// METHOD.md section 3). Both solvers share the full-space local step; the global step is either
// the reduced k x k solve (SemiReducedSolver) or the full n x n CHOLMOD solve (FullSolver, the
// accuracy reference and speed baseline).
//
// Per step, with h = dt, M the lumped masses, g the gravity acceleration:
//   s = x_n + h v_n + h^2 g                       (inertia target)
//   x = s; repeat `iterations` times: local step at x, then global step -> x
//   v_{n+1} = (1 - damping) (x - x_n) / h          (damping in [0, 1), 0 = none: a simple
//                                                   per-step velocity scaling, not Rayleigh)
// A solver holds only workspace (and, for FullSolver, the CHOLMOD factor); step() allocates
// nothing once the workspace exists. A solver serves the one Model it was made for.

#include <memory>

#include "common/eigen_types.hpp"
#include "common/sparse_cholesky.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/local_step.hpp"
#include "runtime/state.hpp"

namespace mat {

struct SolverOptions {
    int iterations = 10; ///< local/global iterations per step, >= 1
    Vec3 gravity = Vec3(0.0, -9.81, 0.0); ///< external acceleration, m/s^2
    double damping = 0.0; ///< velocity scaling per step, in [0, 1)
};

class SemiReducedSolver {
public:
    SemiReducedSolver(const Model& model, const SolverOptions& options = {});

    /// One time step from `in` to `out` (n x 3 each; `out` is resized if needed, and may not be
    /// `in`). `dt` must equal model.time_step(): the system matrix is factored for it.
    void step(const Model& model, const State& in, State& out, double dt);

    /// The reduced coordinates q  k x 3 of the last step (x = X + B q).
    const MatX& reduced_coordinates() const { return m_q; }

private:
    SolverOptions m_options;
    LocalStep m_local;
    MatX3 m_inertia; ///< s  n x 3
    MatX3 m_rhs; ///< local-step right-hand side, then the full-space residual y  n x 3
    MatX m_q; ///< k x 3
};

class FullSolver {
public:
    /// Factors the model's full system with CHOLMOD (throws mat::Error if that fails).
    FullSolver(const Model& model, const SolverOptions& options = {});

    void step(const Model& model, const State& in, State& out, double dt);

private:
    SolverOptions m_options;
    LocalStep m_local;
    SparseCholesky m_cholesky;
    MatX3 m_inertia; ///< s  n x 3
    MatX3 m_rhs; ///< n x 3
};

} // namespace mat
