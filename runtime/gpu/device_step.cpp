#include "runtime/gpu/device_step.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/error.hpp"
#include "common/timer.hpp"
#include "runtime/gpu/device_engine.hpp"
#include "runtime/pd/basis_products.hpp"

namespace mat {

namespace {

    /// The basis in handle form (node by node, as the CPU's products read it, and handle by
    /// handle) and S^-1 into `out`.
    void add_reduced_basis(const Model& model, gpu::EngineModel& out)
    {
        const Index n = model.num_nodes(), k = model.num_columns();
        const Index m = model.handle_centers().rows();
        const BasisProducts products(model);
        if (!products.factored())
            throw_error("--device cuda: the bake's basis is not in handle form (w_ij times the "
                        "monomials of each handle), which the GPU step needs");
        const VecXi& offsets = model.handle_column_offsets();
        for (Index j = 0; j < m; ++j) {
            for (int c = 0; c < 3; ++c)
                out.handle_centers.push_back(model.handle_centers()(j, c));
            out.handle_inverse_scales.push_back(1.0 / model.handle_scales()(j));
            out.handle_offsets.push_back(offsets(j));
            out.handle_terms.push_back(offsets(j + 1) - offsets(j));
        }
        out.node_entry_offsets = products.node_offsets();
        out.node_entry_handles = products.node_handles();
        out.node_entry_weights = products.node_weights();
        const std::size_t entries = out.node_entry_handles.size();
        out.handle_entry_offsets.assign(static_cast<std::size_t>(m) + 1, 0);
        for (const int j : out.node_entry_handles)
            ++out.handle_entry_offsets[static_cast<std::size_t>(j) + 1];
        for (Index j = 0; j < m; ++j)
            out.handle_entry_offsets[j + 1] += out.handle_entry_offsets[j];
        out.handle_entry_nodes.resize(entries);
        out.handle_entry_weights.resize(entries);
        std::vector<int> next(out.handle_entry_offsets.begin(), out.handle_entry_offsets.end() - 1);
        for (Index i = 0; i < n; ++i) // nodes ascending: each handle's entries by node
            for (int e = out.node_entry_offsets[i]; e < out.node_entry_offsets[i + 1]; ++e) {
                const int slot = next[static_cast<std::size_t>(out.node_entry_handles[e])]++;
                out.handle_entry_nodes[slot] = static_cast<int>(i);
                out.handle_entry_weights[slot] = out.node_entry_weights[e];
            }

        // S^-1, as the CPU's reduced step keeps it up to dense_inverse_limit columns.
        const MatX inverse = model.reduced_system().solve(MatX::Identity(k, k));
        out.inverse.resize(static_cast<std::size_t>(k * k));
        for (Index r = 0; r < k; ++r)
            for (Index c = 0; c < k; ++c)
                out.inverse[r * k + c] = inverse(r, c);
    }

    /// The model in the engine's layout (runtime/gpu/device_engine.hpp).
    gpu::EngineModel engine_model(const Model& model, const Vec3& gravity, double damping,
        int iterations, const std::vector<PlaneCollider>& planes, bool exact)
    {
        gpu::EngineModel out;
        const Index n = model.num_nodes(), tets = model.num_tets(), k = model.num_columns();
        const Index m = model.handle_centers().rows();
        out.nodes = static_cast<int>(n);
        out.tets = static_cast<int>(tets);
        out.columns = static_cast<int>(k);
        out.handles = static_cast<int>(m);
        out.time_step = model.time_step();
        out.damping = damping;
        for (int c = 0; c < 3; ++c)
            out.gravity[c] = gravity(c);
        out.iterations = iterations;
        out.weights.volume_tolerance = model.volume_tolerance();
        out.weights.limit_min = model.material().strain_limit_min;
        out.weights.limit_max = model.material().strain_limit_max;
        out.weights.rotation = model.strain_weight();
        out.weights.volume = model.volume_weight();
        out.weights.limit = model.strain_limit_weight();
        out.weights.exact = exact;

        out.tet_nodes.resize(4 * static_cast<std::size_t>(tets));
        out.dm_inverse.resize(9 * static_cast<std::size_t>(tets));
        for (Index e = 0; e < tets; ++e) {
            for (int c = 0; c < 4; ++c)
                out.tet_nodes[4 * e + c] = model.tets()(e, c);
            for (int j = 0; j < 9; ++j)
                out.dm_inverse[9 * e + j] = model.dm_inverse()(e, j);
        }
        out.volumes.assign(model.rest_volumes().data(), model.rest_volumes().data() + tets);
        out.incident_offsets.assign(
            model.incident_indptr().data(), model.incident_indptr().data() + n + 1);
        out.incident_corners.assign(model.incident_corners().data(),
            model.incident_corners().data() + model.incident_corners().size());
        const double* rest = model.rest_positions().data();
        out.rest.assign(rest, rest + 3 * n);
        const double inv_h2 = 1.0 / (model.time_step() * model.time_step());
        out.mass_over_h2.resize(n);
        out.rest_system.resize(3 * static_cast<std::size_t>(n));
        // A X = L_w X + M X / h^2 + P X (as ReducedGlobalStep).
        for (Index i = 0; i < n; ++i) {
            out.mass_over_h2[i] = model.masses()(i) * inv_h2;
            for (int c = 0; c < 3; ++c)
                out.rest_system[3 * i + c]
                    = model.stiffness_rest()(i, c) + out.mass_over_h2[i] * rest[3 * i + c];
        }
        for (const int i : model.pinned_nodes())
            for (int c = 0; c < 3; ++c)
                out.rest_system[3 * i + c] += model.pin_weight() * rest[3 * i + c];
        out.pin_nodes = model.pinned_nodes();
        out.pin_weight = model.pin_weight();
        for (const PlaneCollider& plane : planes) {
            for (int c = 0; c < 3; ++c)
                out.planes.push_back(plane.normal(c));
            out.planes.push_back(plane.normal.dot(plane.point));
        }

        add_reduced_basis(model, out);
        return out;
    }

} // namespace

std::string cuda_unavailable_reason()
{
    return gpu::engine_unavailable_reason();
}

DeviceSemiStep::DeviceSemiStep(const Model& model, const Vec3& gravity, double damping,
    int iterations, const std::vector<PlaneCollider>& planes, bool exact_projections)
{
    const std::string reason = cuda_unavailable_reason();
    if (!reason.empty())
        throw_error("--device cuda: {}", reason);
    if (model.num_columns() == 0)
        throw_error("--device cuda: the body has no reduced basis");
    try {
        m_impl = std::make_unique<gpu::Engine>(
            engine_model(model, gravity, damping, iterations, planes, exact_projections));
    } catch (const std::runtime_error& e) {
        throw_error("--device cuda: {}", e.what());
    }
}

DeviceSemiStep::~DeviceSemiStep() = default;

namespace {
    template <typename F> void guarded(F&& call)
    {
        try {
            call();
        } catch (const std::runtime_error& e) {
            throw_error("--device cuda: {}", e.what());
        }
    }
} // namespace

void DeviceSemiStep::upload_state(const MatX3& positions, const MatX3& velocities)
{
    Timer timer;
    guarded([&] { m_impl->upload_state(positions.data(), velocities.data()); });
    m_timings.upload += timer.seconds();
}

void DeviceSemiStep::begin_step(const MatX3& pin_targets)
{
    guarded([&] { m_impl->begin_step(pin_targets.data()); });
}

const std::vector<double>& DeviceSemiStep::plane_minima() const
{
    return m_impl->plane_minima();
}

void DeviceSemiStep::iterate()
{
    guarded([&] { m_impl->iterate(); });
}

void DeviceSemiStep::iterate_all()
{
    guarded([&] { m_impl->iterate_all(); });
}

void DeviceSemiStep::download_q(MatX& q)
{
    // MatX is column-major; the engine's q is k x 3 row-major.
    m_q_rows.resize(q.rows(), 3);
    guarded([&] { m_impl->download_q(m_q_rows.data()); });
    q = m_q_rows;
}

void DeviceSemiStep::upload_q(const MatX& q)
{
    m_q_rows = q;
    guarded([&] { m_impl->upload_q(m_q_rows.data()); });
}

void DeviceSemiStep::reconstruct()
{
    guarded([&] { m_impl->reconstruct(); });
}

void DeviceSemiStep::download_positions(MatX3& positions)
{
    Timer timer;
    guarded([&] { m_impl->download_positions(positions.data()); });
    m_timings.download += timer.seconds();
}

void DeviceSemiStep::end_step()
{
    guarded([&] { m_impl->end_step(); });
    collect_phases();
    ++m_timings.steps;
}

void DeviceSemiStep::download_state(MatX3& positions, MatX3& velocities)
{
    Timer timer;
    guarded([&] { m_impl->download_state(positions.data(), velocities.data()); });
    m_timings.download += timer.seconds();
}

void DeviceSemiStep::collect_phases()
{
    const gpu::EnginePhases phases = m_impl->take_phases();
    m_timings.local += phases.local;
    m_timings.gather += phases.gather;
    m_timings.rhs += phases.rhs;
    m_timings.solve += phases.solve;
    m_timings.reconstruct += phases.reconstruct;
    m_timings.begin_end += phases.begin_end;
}

void DeviceSemiStep::set_profiling(bool on)
{
    m_impl->set_profiling(on);
}

std::string DeviceSemiStep::description() const
{
    return m_impl->description();
}

} // namespace mat
