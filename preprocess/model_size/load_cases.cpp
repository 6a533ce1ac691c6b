#include "preprocess/model_size/load_cases.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numeric>

#include <Eigen/Geometry>

#include "common/error.hpp"
#include "common/log.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/state.hpp"

namespace mat {

namespace {

    // Box axes from the longest extent to the shortest.
    std::array<int, 3> axes_by_extent(const Box3& box)
    {
        const Vec3 extent = box.sizes();
        std::array<int, 3> order { 0, 1, 2 };
        std::stable_sort(
            order.begin(), order.end(), [&](int a, int b) { return extent(a) > extent(b); });
        return order;
    }

    Vec3 unit(int axis, double sign)
    {
        Vec3 v = Vec3::Zero();
        v(axis) = sign;
        return v;
    }

} // namespace

std::vector<LoadCase> standard_load_cases(const Box3& box)
{
    const std::array<int, 3> axes = axes_by_extent(box);
    std::vector<LoadCase> cases(3);
    cases[0].name = "cantilever-long";
    cases[0].axis = axes[0];
    cases[0].gravity = unit(axes[1], -1.0);
    cases[1].name = "cantilever-second";
    cases[1].axis = axes[1];
    cases[1].gravity = unit(axes[0], -1.0);
    cases[2].name = "twist";
    cases[2].axis = axes[0];
    cases[2].pin_max_end = true;
    cases[2].twist = 30.0 * M_PI / 180.0;
    return cases;
}

void pinned_nodes(const BakeData& bake, const Box3& box, const LoadCase& load,
    std::vector<int>& nodes, MatX3& targets)
{
    const MatX3& rest = bake.tet_mesh.positions;
    const int a = load.axis;
    const double thickness = load.slab * box.sizes()(a);
    const double low = box.min()(a) + thickness;
    const double high = box.max()(a) - thickness;
    // The twist turns the max end about the axis through the center of its slab.
    Vec3 center = box.center();
    center(a) = box.max()(a);
    const Mat3 rotation = Eigen::AngleAxisd(load.twist, unit(a, 1.0)).toRotationMatrix();
    nodes.clear();
    std::vector<Vec3> pins;
    for (Index i = 0; i < rest.rows(); ++i) {
        const Vec3 x = rest.row(i).transpose();
        if (x(a) <= low) {
            nodes.push_back(static_cast<int>(i));
            pins.push_back(x);
        } else if (load.pin_max_end && x(a) >= high) {
            nodes.push_back(static_cast<int>(i));
            pins.push_back(center + rotation * (x - center));
        }
    }
    targets.resize(static_cast<Index>(pins.size()), 3);
    for (std::size_t p = 0; p < pins.size(); ++p)
        targets.row(static_cast<Index>(p)) = pins[p].transpose();
}

StaticSolution solve_static(const BakeData& bake, const Box3& box, const LoadCase& load,
    bool full_space, const StaticSolveOptions& options)
{
    ModelOptions model_options;
    model_options.time_step = options.time_step;
    model_options.pin_weight_scale = options.pin_weight_scale;
    pinned_nodes(bake, box, load, model_options.pinned_nodes, model_options.pin_targets);
    if (model_options.pinned_nodes.empty())
        throw_error("load case {}: no tet-mesh node lies in the pinned slab", load.name);
    const Model model(bake, options.material, model_options);
    SolverOptions solver_options;
    solver_options.iterations = options.iterations_per_step;
    solver_options.gravity = load.gravity;
    solver_options.exact_projections = true;
    std::unique_ptr<PdSolver> solver;
    if (full_space)
        solver = make_solver(SolverKind::full, model, solver_options);
    else
        solver = make_solver(SolverKind::semi_reduced, model, solver_options);

    const double diagonal = box.diagonal().norm();
    State state = State::at_rest(model);
    State next;
    StaticSolution solution;
    for (int step = 0; step < options.max_steps; ++step) {
        solver->step(state, next);
        solution.last_change
            = (next.positions - state.positions).rowwise().norm().maxCoeff() / diagonal;
        // The velocity a static solve carries over is noise: start each step at rest.
        next.velocities.setZero();
        std::swap(state, next);
        solution.steps = step + 1;
        if (solution.last_change <= options.tolerance) {
            solution.converged = true;
            break;
        }
    }
    if (!solution.converged)
        logger().debug("load case {} ({}): not converged after {} steps (last change {:.2e} of "
                       "the diagonal)",
            load.name, full_space ? "full" : "reduced", solution.steps, solution.last_change);
    solution.positions = std::move(state.positions);
    return solution;
}

void calibrate_gravity(const BakeData& bake, const Box3& box, std::vector<LoadCase>& cases,
    double deflection, const StaticSolveOptions& options)
{
    // A small probe load stays in the linear regime, where deflection is proportional to load.
    constexpr double probe = 1e-3;
    StaticSolveOptions probe_options = options;
    probe_options.tolerance *= probe;
    const double diagonal = box.diagonal().norm();
    for (LoadCase& load : cases) {
        if (load.gravity.isZero())
            continue;
        LoadCase probe_case = load;
        probe_case.gravity = probe * load.gravity.normalized();
        const StaticSolution solution = solve_static(bake, box, probe_case, true, probe_options);
        const double moved
            = (solution.positions - bake.tet_mesh.positions).rowwise().norm().maxCoeff();
        if (!(moved > 0.0 && std::isfinite(moved)))
            throw_error("load case {}: the probe load moved no node", load.name);
        load.gravity = probe_case.gravity * (deflection * diagonal / moved);
        logger().debug("load case {}: gravity {:.4g} m/s^2 for a deflection of {:.3g}% of the "
                       "diagonal",
            load.name, load.gravity.norm(), 100.0 * deflection);
    }
}

} // namespace mat
