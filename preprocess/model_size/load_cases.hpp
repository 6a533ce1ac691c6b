#pragma once
// Standard load cases for choosing a model's size (mat-bake --error): quasi-static, nonlinear
// equilibria of a bake under pins and gravity, solved with the runtime's own projective dynamics.
//
// A case is defined on the surface's bounding box, not on a tet mesh, so the same case applies to
// every candidate bake of one surface: the pinned nodes are those within a slab at an end of a
// box axis. A time step far longer than the body's periods (1e3 s: M / h^2 vanishes next to the
// stiffness) makes each implicit Euler step a static solve; steps repeat until the positions stop
// moving.

#include <string>
#include <vector>

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"
#include "runtime/model.hpp"

namespace mat {

struct LoadCase {
    std::string name;
    int axis = 0; ///< the axis whose ends are pinned (0, 1, 2)
    double slab = 0.1; ///< pinned slab thickness, fraction of the box extent along `axis`
    bool pin_max_end = false; ///< pin the slab at the max end too (else only the min end)
    Vec3 gravity = Vec3::Zero(); ///< acceleration, m/s^2 (scaled by calibrate_gravity)
    double twist = 0.0; ///< rotation of the max end's pin targets about `axis`, radians
};

/// Three cases on `box` (the rest surface's bounding box): a cantilever along the longest axis
/// sagging along the second longest, a cantilever along the second longest sagging along the
/// longest, and both ends of the longest axis pinned with the max end twisted by 30 degrees.
/// Gravity has unit magnitude until calibrate_gravity scales it.
std::vector<LoadCase> standard_load_cases(const Box3& box);

struct StaticSolveOptions {
    Material material; ///< default: E 1e5 Pa, nu 0.3, 1000 kg/m^3
    double time_step = 1e3; ///< s: long enough that one step is a static solve
    int iterations_per_step = 50; ///< PD iterations per step, >= 1
    int max_steps = 12; ///< steps at most
    /// Pin stiffness relative to the largest diagonal entry of the system (ModelOptions). Soft
    /// (1, not the runtime's 1e8) so that a reduced model is not locked by the small tails of
    /// far handles' weights on the pinned nodes: with 1e8 those tails hold every handle still.
    double pin_weight_scale = 1.0;
    double tolerance = 1e-5; ///< stop when no node moved more than this x the box diagonal
};

/// The equilibrium of one case.
struct StaticSolution {
    MatX3 positions; ///< n x 3 node positions
    int steps = 0;
    double last_change = 0.0; ///< largest node motion in the last step, fraction of the diagonal
    bool converged = false;
};

/// Pinned nodes of `load` on the bake's tet mesh, with their targets  #pinned x 3.
void pinned_nodes(const BakeData& bake, const Box3& box, const LoadCase& load,
    std::vector<int>& nodes, MatX3& targets);

/// Solves `load` on `bake` in full space (full_solver) or reduced (semi_reduced_solver). Throws
/// mat::Error if no node is pinned or the solve fails.
StaticSolution solve_static(const BakeData& bake, const Box3& box, const LoadCase& load,
    bool full_space, const StaticSolveOptions& options);

/// Scales each gravity case's load so that its full-space equilibrium on `bake` moves some node
/// by `deflection` x the box diagonal (from a linear-regime solve at a small load).
void calibrate_gravity(const BakeData& bake, const Box3& box, std::vector<LoadCase>& cases,
    double deflection, const StaticSolveOptions& options);

} // namespace mat
