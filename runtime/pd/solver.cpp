#include "runtime/pd/solver.hpp"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/timer.hpp"

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

} // namespace

PdSolver::PdSolver(const Model& model, const SolverOptions& options,
    std::unique_ptr<GlobalStep> global, bool full_local_step)
    : m_model(&model)
    , m_options(options)
    , m_global(std::move(global))
    , m_local(
          full_local_step ? std::make_unique<LocalStep>(model, options.exact_projections) : nullptr)
    , m_pin_targets(model.pin_targets())
    , m_inertia(model.num_nodes(), 3)
    , m_rhs(model.num_nodes(), 3)
    , m_rhs_base(model.num_nodes(), 3)
{
    check_options(options);
    m_fill_column = [this](Index b) {
        for (Index a = 0; a < static_cast<Index>(m_pairs.size()); ++a)
            m_coupling(a, b) = m_global->coupling(m_pairs[a].node, m_pairs[b].node);
    };
    const MatX3& rest = model.rest_positions();
    const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
    m_margin = options.contact_margin * diagonal;
    m_options.contact.tolerance = options.contact.tolerance * diagonal;
    m_previous_forces
        = MatX3::Zero(model.num_nodes() * static_cast<Index>(options.planes.size()), 3);
    m_previous_node_forces = MatX3::Zero(model.num_nodes(), 3);
    if (!options.planes.empty())
        m_boundary = boundary_nodes(model.tets(), model.num_nodes());
}

void PdSolver::set_pin_targets(const Eigen::Ref<const MatX3>& targets)
{
    if (targets.rows() != m_pin_targets.rows())
        throw_error("solver: {} pin targets given for {} pinned nodes", targets.rows(),
            m_pin_targets.rows());
    if (!targets.allFinite())
        throw_error("solver: the pin targets are not finite");
    m_pin_targets = targets;
}

void PdSolver::set_node_contacts(std::vector<NodeContact> contacts)
{
    const Index n = m_model->num_nodes();
    for (const NodeContact& c : contacts) {
        if (c.node < 0 || c.node >= n)
            throw_error("solver: contact node {} out of range [0, {})", c.node, n);
        if (!c.plane.point.allFinite() || std::abs(c.plane.normal.norm() - 1.0) > 1e-9
            || !(c.plane.friction >= 0.0))
            throw_error("solver: contact at node {} has a bad plane", c.node);
    }
    m_node_contacts = std::move(contacts);
}

void PdSolver::local_global(const Model& model, int /*iteration*/,
    const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3>& base)
{
    MAT_CHECK(m_local != nullptr, "solver: made without the full local step");
    Timer timer;
    MAT_CHECK(base.rows() == model.num_nodes(), "solver: base has {} rows for {} nodes",
        base.rows(), model.num_nodes());
    if (m_global->takes_local_sums() && base.outerStride() == 3) {
        // The global step reads base + the local step's sums node by node.
        m_local->project(model, positions);
        m_timings.local += timer.seconds();
        m_global->solve(m_local->sums(base.data()), m_timings);
        return;
    }
    m_local->assemble(model, positions, base, m_rhs);
    m_timings.local += timer.seconds();
    m_global->solve(m_rhs, m_timings);
}

// Candidates: boundary nodes within the margin of a plane at the start of the step or at the
// inertia target (the iterates move from s towards an equilibrium near both).
void PdSolver::find_contacts(const State& in)
{
    const Index num_planes = static_cast<Index>(m_options.planes.size());
    m_old_pairs.swap(m_pairs);
    m_pairs.clear();
    m_pair_nodes.clear();
    m_unique_nodes.clear();
    for (const int i : m_boundary) {
        bool any = false;
        for (std::size_t p = 0; p < m_options.planes.size(); ++p) {
            const PlaneCollider& plane = m_options.planes[p];
            const double at_start = plane.normal.dot(in.positions.row(i).transpose() - plane.point);
            const double at_target = plane.normal.dot(m_inertia.row(i).transpose() - plane.point);
            if (std::min(at_start, at_target) < m_margin) {
                m_pairs.push_back(ContactPair { i, static_cast<int>(p) });
                m_pair_nodes.push_back(i);
                any = true;
            }
        }
        if (any)
            m_unique_nodes.push_back(i);
    }
    // Node contacts, each with a plane of its own after the ground planes. Warm start: the
    // node's node-contact force of the last step.
    m_step_planes.assign(m_options.planes.begin(), m_options.planes.end());
    const Index ground_pairs = static_cast<Index>(m_pairs.size());
    for (const NodeContact& c : m_node_contacts) {
        m_pairs.push_back(ContactPair { c.node, static_cast<int>(m_step_planes.size()) });
        m_step_planes.push_back(c.plane);
        m_step_planes.back().compliance = m_options.node_contact_compliance;
        m_pair_nodes.push_back(c.node);
        m_unique_nodes.push_back(c.node);
    }
    std::sort(m_unique_nodes.begin(), m_unique_nodes.end());
    m_unique_nodes.erase(
        std::unique(m_unique_nodes.begin(), m_unique_nodes.end()), m_unique_nodes.end());
    const Index m = static_cast<Index>(m_pairs.size());
    m_global->prepare_nodes(m_unique_nodes);
    if (m_coupling.rows() != m || m_contact_free.rows() != m) {
        m_coupling.resize(m, m);
        m_contact_free.resize(m, 3);
        m_contact_start.resize(m, 3);
        m_contact_forces.resize(m, 3);
        m_contact_positions.resize(m, 3);
    }
    // Only the diagonal now: a column is computed when its contact first pushes.
    m_column_ready.assign(m, 0);
    for (Index a = 0; a < m; ++a)
        m_coupling(a, a) = m_global->coupling(m_pairs[a].node, m_pairs[a].node);
    for (Index a = 0; a < m; ++a) {
        m_contact_start.row(a) = in.positions.row(m_pairs[a].node);
        m_contact_forces.row(a) = a < ground_pairs
            ? m_previous_forces.row(m_pairs[a].node * num_planes + m_pairs[a].plane)
            : m_previous_node_forces.row(m_pairs[a].node);
    }
    // The last step's forces are read: forget them, so that a pair that drops out and comes
    // back later does not start from a stale force (the step's end writes the current ones).
    for (const ContactPair& pair : m_old_pairs) {
        if (pair.plane < num_planes)
            m_previous_forces.row(pair.node * num_planes + pair.plane).setZero();
        else
            m_previous_node_forces.row(pair.node).setZero();
    }
}

void PdSolver::step(const Model& model, const State& in, State& out, double dt)
{
    const Index n = model.num_nodes();
    if (&model != m_model)
        throw_error("solver: step() was given another model than the solver was made for");
    if (in.positions.rows() != n || in.velocities.rows() != n)
        throw_error("solver: state has {} positions and {} velocities, the model has {} nodes",
            in.positions.rows(), in.velocities.rows(), n);
    if (&in == &out)
        throw_error("solver: the input and output states must be different objects");
    if (std::abs(dt - model.time_step()) > 1e-12 * model.time_step())
        throw_error("solver: time step {} differs from the model's {} (its matrices are factored "
                    "for it)",
            dt, model.time_step());
    const double h = dt;
    const double inv_h2 = 1.0 / (h * h);
    const VecX& masses = model.masses();
    const auto& pins = model.pinned_nodes();
    m_report = StepReport {};

    // s = x_n + h v_n + h^2 g  (Bouaziz et al. 2014, eq. 9 with f_ext = M g).
    Timer timer;
    const Eigen::RowVector3d shift = (h * h) * m_options.gravity.transpose();
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            m_inertia.row(i) = in.positions.row(i) + h * in.velocities.row(i) + shift;
    });
    out.positions = m_inertia;
    // b = M s / h^2 + P p + r  (Bouaziz et al. 2014, eq. 13 with pins): all but the local step's
    // r are the same in every iteration of the step.
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            m_rhs_base.row(i) = (masses(i) * inv_h2) * m_inertia.row(i);
    });
    for (std::size_t p = 0; p < pins.size(); ++p)
        m_rhs_base.row(pins[p]) += model.pin_weight() * m_pin_targets.row(static_cast<Index>(p));
    m_global->add_constant_terms(m_rhs_base);
    m_timings.rhs += timer.seconds();

    timer.restart();
    if (!m_options.planes.empty() || !m_node_contacts.empty() || !m_pairs.empty())
        find_contacts(in);
    m_node_contacts.clear(); // they hold for this step only
    m_timings.contact += timer.seconds();
    const Index m = static_cast<Index>(m_pairs.size());

    for (int iteration = 0; iteration < m_options.iterations; ++iteration) {
        local_global(model, iteration, out.positions, m_rhs_base);

        if (m > 0) {
            timer.restart();
            for (Index a = 0; a < m; ++a)
                m_contact_free.row(a) = m_global->node_position(m_pairs[a].node).transpose();
            const ContactSolveResult result = solve_plane_contacts(m_coupling, m_column_ready,
                m_fill_column, m_step_planes, m_pairs, m_contact_free, m_contact_start,
                m_contact_forces, m_contact_positions, m_options.contact, m_contact_scratch);
            m_report.contact_sweeps += result.sweeps;
            m_global->add_forces(m_pair_nodes, m_contact_forces);
            m_timings.contact += timer.seconds();
        }
        if (reads_iterate() || iteration + 1 == m_options.iterations)
            m_global->positions(out.positions, m_timings);
        ++m_timings.iterations;
    }

    m_report.contacts = static_cast<int>(m);
    const Index num_planes = static_cast<Index>(m_options.planes.size());
    for (Index a = 0; a < m; ++a) {
        const ContactPair& pair = m_pairs[a];
        if (pair.plane < num_planes)
            m_previous_forces.row(pair.node * num_planes + pair.plane) = m_contact_forces.row(a);
        else
            m_previous_node_forces.row(pair.node) = m_contact_forces.row(a);
        if (m_contact_forces.row(a).squaredNorm() > 0.0)
            ++m_report.active_contacts;
        const PlaneCollider& plane = m_step_planes[pair.plane];
        const double gap = plane.normal.dot(out.positions.row(pair.node).transpose() - plane.point);
        m_report.max_penetration = std::max(m_report.max_penetration, -gap);
    }

    // v = (1 - damping) (x - x_n) / h.
    const double scale = (1.0 - m_options.damping) / h;
    out.velocities.resize(n, 3);
    tbb::parallel_for(tbb::blocked_range<Index>(0, n), [&](const tbb::blocked_range<Index>& range) {
        for (Index i = range.begin(); i != range.end(); ++i)
            out.velocities.row(i) = scale * (out.positions.row(i) - in.positions.row(i));
    });
    if (!out.positions.allFinite())
        throw_error("projective dynamics: the positions are not finite after the step");
    ++m_timings.steps;
}

SemiReducedSolver::SemiReducedSolver(const Model& model, const SolverOptions& options)
    : PdSolver(model, options, std::make_unique<ReducedGlobalStep>(model))
    , m_reduced(static_cast<const ReducedGlobalStep*>(&global_step()))
{
}

FullSolver::FullSolver(const Model& model, const SolverOptions& options)
    : PdSolver(model, options, std::make_unique<FullGlobalStep>(model))
{
}

} // namespace mat
