#include "runtime/pd/solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/timer.hpp"
#include "runtime/pd/hyper_reduced.hpp"
#include "runtime/pd/pd_energy.hpp"
#include "runtime/pd/pin_term.hpp"

namespace mat {

namespace {

    void check_options(const SolverOptions& options)
    {
        if (options.iterations < 1)
            throw_error("solver: iterations {} must be at least 1", options.iterations);
        if (!(options.damping >= 0.0 && options.damping < 1.0))
            throw_error("solver: damping {} must be in [0, 1)", options.damping);
        if (!(options.node_contact_compliance >= 0.0))
            throw_error("solver: node contact compliance {} must be non-negative",
                options.node_contact_compliance);
        if (options.anderson_window < 1 || options.anderson_window > anderson_max_window)
            throw_error("solver: anderson_window {} must be in [1, {}]", options.anderson_window,
                anderson_max_window);
        if (!(options.tolerance >= 0.0) || !std::isfinite(options.tolerance))
            throw_error("solver: tolerance {} must be finite and non-negative", options.tolerance);
        if (!(options.contact_margin >= 0.0))
            throw_error("solver: contact margin {} must be non-negative", options.contact_margin);
        for (std::size_t p = 0; p < options.planes.size(); ++p) {
            const PlaneCollider& plane = options.planes[p];
            if (!plane.point.allFinite() || std::abs(plane.normal.norm() - 1.0) > 1e-9)
                throw_error("solver: plane {} needs a finite point and a unit normal", p);
            if (!(plane.friction >= 0.0) || !std::isfinite(plane.friction))
                throw_error("solver: plane {} friction {} must be non-negative", p, plane.friction);
        }
    }

    /// The mass of each entry of the global step's solution: the node masses in full space (x
    /// n x 3 row-major: the M-norm), the diagonal of B^T M B reduced (q  k x 3 column-major).
    VecX solution_masses(const Model& model, bool reduced)
    {
        const VecX& masses = model.masses();
        const Index n = model.num_nodes();
        VecX weights;
        if (!reduced) {
            weights.resize(3 * n);
            for (Index i = 0; i < n; ++i)
                weights.segment<3>(3 * i).setConstant(masses(i));
        } else {
            const Index k = model.num_columns();
            VecX diagonal = VecX::Zero(k);
            for (Index i = 0; i < n; ++i)
                for (SparseRowMatrix::InnerIterator it(model.basis(), i); it; ++it)
                    diagonal(it.index()) += masses(i) * it.value() * it.value();
            const double floor = 1e-12 * std::max(diagonal.maxCoeff(), 1e-300);
            weights.resize(3 * k);
            for (int c = 0; c < 3; ++c)
                weights.segment(c * k, k) = diagonal.cwiseMax(floor);
        }
        return weights;
    }

    /// The weights of Anderson's least squares: solution_masses scaled to a mean of 1.
    /// Unweighted, the coordinates of quadratic handles (monomials of the rest positions, small)
    /// count for more than they move.
    VecX acceleration_weights(const Model& model, bool reduced)
    {
        const VecX weights = solution_masses(model, reduced);
        return weights / weights.mean();
    }

    /// A step's states: `in` of n nodes, `out` another object.
    void check_step_states(const State& in, const State& out, Index n)
    {
        if (in.positions.rows() != n || in.velocities.rows() != n)
            throw_error("solver: state has {} positions and {} velocities, the model has {} nodes",
                in.positions.rows(), in.velocities.rows(), n);
        if (&in == &out)
            throw_error("solver: the input and output states must be different objects");
    }

    /// s = x_n + h v_n + h^2 g.
    void inertia_positions(const State& in, double h, const Vec3& gravity, MatX3& s)
    {
        const Eigen::RowVector3d shift = (h * h) * gravity.transpose();
        tbb::parallel_for(tbb::blocked_range<Index>(0, in.positions.rows()),
            [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    s.row(i) = in.positions.row(i) + h * in.velocities.row(i) + shift;
            });
    }

} // namespace

SolverKind parse_solver_kind(const std::string& name)
{
    if (name == "semi")
        return SolverKind::semi_reduced;
    if (name == "full")
        return SolverKind::full;
    if (name == "hyper")
        return SolverKind::hyper_reduced;
    throw_error("--solver: '{}' is not a solver (expected semi, full or hyper)", name);
}

Acceleration parse_acceleration(const std::string& name)
{
    if (name == "none")
        return Acceleration::none;
    if (name == "anderson")
        return Acceleration::anderson;
    throw_error("acceleration: '{}' is not one (expected none or anderson)", name);
}

PdSolver semi_reduced_solver(const Model& model, const SolverOptions& options)
{
    return PdSolver(model, options,
        std::make_unique<EveryTetLocalStage>(model, options.exact_projections),
        std::make_unique<ReducedGlobalStep>(model));
}

PdSolver full_solver(const Model& model, const SolverOptions& options)
{
    return PdSolver(model, options,
        std::make_unique<EveryTetLocalStage>(model, options.exact_projections),
        std::make_unique<FullGlobalStep>(model));
}

PdSolver hyper_reduced_solver(const Model& model, const SolverOptions& options, Index samples)
{
    auto global = std::make_unique<ReducedGlobalStep>(model);
    auto local
        = std::make_unique<SampledLocalStage>(model, options.exact_projections, samples, *global);
    return PdSolver(model, options, std::move(local), std::move(global));
}

std::unique_ptr<PdSolver> make_solver(
    SolverKind kind, const Model& model, const SolverOptions& options, Index hyper_samples)
{
    switch (kind) {
    case SolverKind::full:
        return std::make_unique<PdSolver>(full_solver(model, options));
    case SolverKind::hyper_reduced:
        return std::make_unique<PdSolver>(hyper_reduced_solver(model, options, hyper_samples));
    case SolverKind::semi_reduced:
        break;
    }
    return std::make_unique<PdSolver>(semi_reduced_solver(model, options));
}

EveryTetLocalStage::EveryTetLocalStage(const Model& model, bool exact_projections)
    : m_local(model, exact_projections)
    , m_rhs(model.num_nodes(), 3)
    , m_num_tets(model.num_tets())
{
}

void EveryTetLocalStage::iterate(const Model& model, int /*iteration*/,
    const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3>& base,
    GlobalStep& global, SolverTimings& timings)
{
    Timer timer;
    MAT_CHECK(base.rows() == model.num_nodes(), "solver: base has {} rows for {} nodes",
        base.rows(), model.num_nodes());
    if (global.takes_local_sums() && base.outerStride() == 3) {
        // The global step reads base + the local step's sums node by node.
        m_local.project(model, positions);
        timings.local += timer.seconds();
        global.solve(m_local.sums(base.data()), timings);
        return;
    }
    m_local.assemble(model, positions, base, m_rhs);
    timings.local += timer.seconds();
    global.solve(m_rhs, timings);
}

double EveryTetLocalStage::energy(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3>& inertia, const Eigen::Ref<const MatX3>& pin_targets)
{
    return inertia_energy(model, positions, inertia) + pin_energy(model, positions, pin_targets)
        + m_local.energy();
}

PdSolver::PdSolver(const Model& model, const SolverOptions& options,
    std::unique_ptr<LocalStage> local, std::unique_ptr<GlobalStep> global)
    : m_model(&model)
    , m_options(options)
    , m_local(std::move(local))
    , m_global(std::move(global))
    , m_pin_targets(model.pin_targets())
    , m_inertia(model.num_nodes(), 3)
    , m_rhs_base(model.num_nodes(), 3)
{
    MAT_CHECK(m_local != nullptr && m_global != nullptr, "solver: a part is missing");
    check_options(options);
    const MatX3& rest = model.rest_positions();
    const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
    // With time.tolerance the contact solve stops well below it (a tenth), else its own
    // stopping point is a floor the iterations cannot converge past (docs/method.md, "Iterations
    // to a tolerance").
    const double contact_tolerance = options.tolerance > 0.0
        ? std::min(options.contact.tolerance, 0.1 * options.tolerance)
        : options.contact.tolerance;
    m_options.contact.tolerance = contact_tolerance * diagonal;
    m_diagonal = diagonal;
    if (options.device == Device::cuda) {
        if (m_global->reduced_coordinates() == nullptr || m_local->num_tets() != model.num_tets())
            throw_error("--device cuda runs the semi-reduced solver only (--solver semi)");
        if (options.acceleration != Acceleration::none)
            throw_error("--device cuda: solver.acceleration must be none (Anderson acceleration "
                        "runs on the CPU only)");
        if (options.tolerance > 0.0)
            throw_error("--device cuda: time.tolerance must be 0 (the GPU runs a step's "
                        "iterations as one graph)");
        m_device = std::make_unique<DeviceSemiStep>(model, options.gravity, options.damping,
            options.iterations, options.planes, options.exact_projections);
        m_device_margin = options.contact_margin * diagonal;
        m_device_q.resize(model.num_columns(), 3);
    }
}

PdSolver::~PdSolver() = default;

void PdSolver::set_pin_targets(const Eigen::Ref<const MatX3>& targets)
{
    if (targets.rows() != m_pin_targets.rows())
        throw_error("solver: {} pin targets given for {} pinned nodes", targets.rows(),
            m_pin_targets.rows());
    if (!targets.allFinite())
        throw_error("solver: the pin targets are not finite");
    m_pin_targets = targets;
}

void PdSolver::step(const State& in, State& out)
{
    if (!m_own_contacts) {
        m_own_contacts = std::make_unique<ContactStage>(1);
        m_own_state.resize(1);
    }
    begin_step(in, out);
    m_own_state[0] = ContactBodyState { this, &in.positions, &in.positions };
    Timer timer;
    m_own_contacts->begin_step(m_own_state, BodyContacts {});
    m_timings.contact += timer.seconds();
    bool last = false;
    for (int iteration = 0; !last; ++iteration) {
        last = is_last_iteration(iteration);
        iterate(iteration);
        m_own_contacts->solve(last);
        finish_iteration(iteration, last);
    }
    m_own_contacts->end_step();
    end_step();
}

void PdSolver::begin_step(const State& in, State& out)
{
    if (m_device) {
        device_begin_step(in, out);
        return;
    }
    const Model& model = *m_model;
    const Index n = model.num_nodes();
    check_step_states(in, out, n);
    m_in = &in;
    m_out = &out;
    const double h = model.time_step();
    const double inv_h2 = 1.0 / (h * h);
    const VecX& masses = model.masses();
    m_report = StepReport {};

    // s = x_n + h v_n + h^2 g  (Bouaziz et al. 2014, eq. 9 with f_ext = M g).
    Timer timer;
    inertia_positions(in, h, m_options.gravity, m_inertia);
    out.positions = m_inertia;
    // b = M s / h^2 + P p + r  (Bouaziz et al. 2014, eq. 13 with pins): all but the local step's
    // r are the same in every iteration of the step.
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            m_rhs_base.row(i) = (masses(i) * inv_h2) * m_inertia.row(i);
    });
    add_pin_term(model, m_pin_targets, m_rhs_base);
    m_global->add_constant_terms(m_rhs_base);
    m_timings.rhs += timer.seconds();
    m_contact_nodes = 0; // the contact stage's begin_step sets it
    m_change = std::numeric_limits<double>::infinity();
}

void PdSolver::iterate(int iteration)
{
    MAT_CHECK(m_out != nullptr, "solver: iterate() outside a step");
    if (m_device) {
        device_iterate(iteration);
        return;
    }
    if (iteration == 0)
        begin_acceleration();
    m_local->iterate(*m_model, iteration, m_out->positions, m_rhs_base, *m_global, m_timings);
    if (m_accelerating)
        safeguard(iteration);
}

void PdSolver::begin_acceleration()
{
    // Only in steps without contact candidates: the energy does not see the contact forces, and
    // an extrapolation of contact-corrected iterates can leave the contact set (docs/method.md,
    // "Accelerated iterations"). Two iterations or fewer leave nothing to extrapolate.
    m_accelerating = m_options.acceleration == Acceleration::anderson && m_contact_nodes == 0
        && m_options.iterations > 2;
    m_extrapolated = false;
    m_local->set_energy(m_accelerating && m_local->descends());
    if (!m_accelerating)
        return;
    const Eigen::Map<VecX> solution = m_global->solution();
    if (m_anderson_weights.size() != solution.size())
        m_anderson_weights
            = acceleration_weights(*m_model, m_global->reduced_coordinates() != nullptr);
    m_anderson.configure(solution.size(), m_options.anderson_window, m_anderson_weights);
    // Full space iterates positions, and s is the first of them; a reduced one starts from its
    // first solve (s is outside the subspace).
    if (m_global->reduced_coordinates() == nullptr)
        m_anderson.start(m_inertia.data());
}

double PdSolver::safeguard_measure()
{
    if (m_local->descends())
        return m_local->energy(*m_model, m_out->positions, m_inertia, m_pin_targets);
    // |G(u) - u|_W of the iterate u the solve read (none before the history starts: s is
    // outside the subspace).
    if (!m_anderson.started())
        return std::numeric_limits<double>::infinity();
    return m_anderson.residual_norm(m_global->solution().data());
}

void PdSolver::safeguard(int iteration)
{
    Timer timer;
    double measure = safeguard_measure();
    if (m_extrapolated && !(measure <= m_report.energy)) {
        // Refused: back to the plain iterate, the history cleared, and the iteration again.
        Eigen::Map<VecX> solution = m_global->solution();
        m_anderson.fall_back(solution.data());
        if (m_local->reads_iterate())
            m_global->positions(m_out->positions, m_timings);
        m_local->iterate(*m_model, iteration, m_out->positions, m_rhs_base, *m_global, m_timings);
        measure = safeguard_measure();
        ++m_report.rejected;
        ++m_timings.refused;
    } else if (m_extrapolated) {
        ++m_report.accelerated;
        ++m_timings.accelerated;
    }
    m_report.energy = measure;
    m_extrapolated = false;
    m_timings.acceleration += timer.seconds();
}

void PdSolver::finish_iteration(int iteration, bool last)
{
    if (m_device) {
        device_finish_iteration(last);
        return;
    }
    if (m_accelerating && !last) {
        // The next iterate from this one's solve (after the contact stage, which found no
        // candidates): the last solve is kept plain, so the step ends on an accepted iterate.
        Timer timer;
        Eigen::Map<VecX> solution = m_global->solution();
        if (!m_anderson.started())
            m_anderson.start(solution.data());
        else
            m_extrapolated = m_anderson.advance(solution.data());
        m_timings.acceleration += timer.seconds();
    }
    if (m_local->reads_iterate() || last)
        m_global->positions(m_out->positions, m_timings);
    if (m_options.tolerance > 0.0 && !last)
        measure_change(iteration);
    ++m_timings.iterations;
}

bool PdSolver::is_last_iteration(int iteration) const
{
    return iteration + 1 >= m_options.iterations || (iteration > 0 && converged());
}

// How far the iterate still is from the converged step, estimated from its changes
// (docs/method.md, "Iterations to a tolerance"): c_k = |u_k - u_{k-1}|_W / sqrt(sum m) /
// diagonal, with W the solution's masses (solution_masses: the M-norm of x in full space, the
// diagonal of B^T M B on q reduced). The iteration converges linearly, so what is left is
// about c_k rho / (1 - rho), rho the contraction; rho is taken as the larger of the last two
// ratios c_k / c_{k-1}, and at 1 or more the estimate is infinite.
void PdSolver::measure_change(int iteration)
{
    const Eigen::Map<VecX> solution = m_global->solution();
    if (m_solution_masses.size() != solution.size()) {
        m_solution_masses = solution_masses(*m_model, m_global->reduced_coordinates() != nullptr);
        m_previous_solution.resize(solution.size());
    }
    constexpr double infinity = std::numeric_limits<double>::infinity();
    if (iteration == 0) {
        m_changes = { infinity, infinity, infinity };
    } else {
        double sum = 0.0;
        for (Index j = 0; j < solution.size(); ++j) {
            const double d = solution(j) - m_previous_solution(j);
            sum += m_solution_masses(j) * d * d;
        }
        m_changes
            = { std::sqrt(sum / m_model->masses().sum()) / m_diagonal, m_changes[0], m_changes[1] };
    }
    m_previous_solution = solution;
    m_change = infinity;
    if (!std::isfinite(m_changes[2]))
        return; // fewer than three changes yet
    const double rho = std::max(m_changes[0] / m_changes[1], m_changes[1] / m_changes[2]);
    if (rho < 1.0) // (false for NaN: two iterates alike)
        m_change = m_changes[0] * rho / (1.0 - rho);
}

void PdSolver::end_step()
{
    MAT_CHECK(m_in != nullptr && m_out != nullptr, "solver: end_step() outside a step");
    if (m_device) {
        device_end_step();
        return;
    }
    const State& in = *m_in;
    State& out = *m_out;
    const Index n = m_model->num_nodes();
    // v = (1 - damping) (x - x_n) / h.
    const double scale = (1.0 - m_options.damping) / m_model->time_step();
    out.velocities.resize(n, 3);
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            out.velocities.row(i) = scale * (out.positions.row(i) - in.positions.row(i));
    });
    // Internal forces exert no net moment (runtime/pd/angular_momentum.hpp): kept for a body
    // without pins that has no contact candidates (free) or whose contact island the world
    // does not hold (keep).
    const bool unpinned = m_model->pinned_nodes().empty();
    if ((m_options.angular_momentum == AngularMomentum::free && unpinned && m_contact_nodes == 0)
        || (m_options.angular_momentum == AngularMomentum::keep && unpinned
            && !m_report.world_held))
        m_angular.apply(m_model->masses(), in.positions, in.velocities, out.positions,
            m_model->time_step(), m_report.contact_impulse, m_report.contact_moment,
            1.0 - m_options.damping, out.velocities);
    m_in = nullptr;
    m_out = nullptr;
    if (!out.positions.allFinite())
        throw_error("projective dynamics: the positions are not finite after the step");
    ++m_timings.steps;
}

// ---- the GPU step (docs/gpu.md) ---------------------------------------------------------------

void PdSolver::device_begin_step(const State& in, State& out)
{
    const Model& model = *m_model;
    const Index n = model.num_nodes();
    check_step_states(in, out, n);
    m_in = &in;
    m_out = &out;
    m_report = StepReport {};
    Timer timer;
    out.positions.resize(n, 3);
    out.velocities.resize(n, 3);
    // The GPU holds `in` if it is the last step's result (the driver swaps the matrices, so
    // their storage identifies it) and nothing wrote it since.
    if (!holds_on_device(in))
        m_device->upload_state(in.positions, in.velocities);
    m_device_x = nullptr; // `in` is read, not held, from here on
    m_device->begin_step(m_pin_targets);
    m_planes_near = false;
    for (const double distance : m_device->plane_minima())
        m_planes_near = m_planes_near || distance < m_device_margin;
    if (m_planes_near) {
        // The contact stage finds the ground candidates at x_n and at s on the CPU.
        if (in.positions.data() == m_device_x_last && !m_host_current) {
            // The state's own values, brought over (see sync_state).
            m_device->download_state(
                const_cast<MatX3&>(in.positions), const_cast<MatX3&>(in.velocities));
            m_host_current = true;
        }
        inertia_positions(in, model.time_step(), m_options.gravity, m_inertia);
    }
    m_timings.device += timer.seconds();
    m_contact_nodes = 0; // the contact stage's begin_step sets it
}

void PdSolver::device_iterate(int iteration)
{
    Timer timer;
    if (m_contact_nodes == 0) {
        // No contact: every iteration at once, on the GPU.
        if (iteration == 0)
            m_device->iterate_all();
    } else {
        m_device->iterate();
        m_device->download_q(m_device_q);
        m_global->set_reduced_coordinates(m_device_q);
    }
    m_timings.device += timer.seconds();
}

void PdSolver::device_finish_iteration(bool last)
{
    Timer timer;
    if (m_contact_nodes > 0) {
        // The contact stage's forces have moved q on the CPU.
        m_device->upload_q(*m_global->reduced_coordinates());
        m_device->reconstruct();
        if (last) // the contact stage's report reads them
            m_device->download_positions(m_out->positions);
    }
    ++m_timings.iterations;
    m_timings.device += timer.seconds();
}

void PdSolver::device_end_step()
{
    Timer timer;
    m_device->end_step();
    // The result stays on the GPU; the host's copy of `out` is brought over by sync_state().
    m_device_x = m_out->positions.data();
    m_device_v = m_out->velocities.data();
    m_device_x_last = m_device_x;
    m_host_current = false;
    m_q_current = false;
    m_timings.device += timer.seconds();
    m_in = nullptr;
    m_out = nullptr;
    ++m_timings.steps;
}

bool PdSolver::holds_on_device(const State& state) const
{
    return m_device && m_device_x != nullptr && state.positions.data() == m_device_x
        && state.velocities.data() == m_device_v;
}

void PdSolver::sync_state(State& state)
{
    if (!m_device || m_in != nullptr)
        return;
    if (!m_host_current && state.positions.data() == m_device_x_last) {
        Timer timer;
        m_device->download_state(state.positions, state.velocities);
        m_host_current = true;
        m_timings.device += timer.seconds();
        if (!state.positions.allFinite())
            throw_error("projective dynamics: the positions are not finite after the step");
    }
    if (!m_q_current) {
        m_device->download_q(m_device_q);
        m_global->set_reduced_coordinates(m_device_q);
        m_q_current = true;
    }
}

void PdSolver::state_written()
{
    m_device_x = nullptr;
    m_device_v = nullptr;
}

} // namespace mat
