#include "runtime/model.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"

namespace mat {

namespace {

    void check_bake(const BakeData& bake)
    {
        const Index n = bake.tet_mesh.num_vertices();
        const Index t = bake.tet_mesh.num_tets();
        const Index k = bake.basis.cols();
        if (n == 0 || t == 0)
            throw_error("model: the bake has an empty tet mesh ({} nodes, {} tets)", n, t);
        if (bake.dm_inverse.rows() != t || bake.dm_inverse.cols() != 9)
            throw_error("model: dm_inverse is {} x {}, expected {} x 9", bake.dm_inverse.rows(),
                bake.dm_inverse.cols(), t);
        if (bake.rest_volumes.size() != t)
            throw_error(
                "model: rest_volumes has {} entries, expected {}", bake.rest_volumes.size(), t);
        if (bake.lumped_mass.size() != n)
            throw_error(
                "model: lumped_mass has {} entries, expected {}", bake.lumped_mass.size(), n);
        if (bake.laplacian.rows() != n || bake.laplacian.cols() != n)
            throw_error("model: laplacian is {} x {}, expected {} x {}", bake.laplacian.rows(),
                bake.laplacian.cols(), n, n);
        if (bake.basis.rows() != n || k == 0)
            throw_error("model: basis is {} x {}, expected {} rows and at least one column",
                bake.basis.rows(), k, n);
        if (bake.reduced_laplacian.rows() != k || bake.reduced_laplacian.cols() != k
            || bake.reduced_mass.rows() != k || bake.reduced_mass.cols() != k)
            throw_error("model: reduced_laplacian / reduced_mass must be {} x {}", k, k);
        for (Index e = 0; e < t; ++e)
            for (int c = 0; c < 4; ++c) {
                const int v = bake.tet_mesh.tets(e, c);
                if (v < 0 || v >= n)
                    throw_error("model: tet {} has node index {} out of range [0, {})", e, v, n);
            }
    }

} // namespace

Model::Model(const BakeData& bake, const Material& material, const ModelOptions& options)
    : m_material(material)
    , m_time_step(options.time_step)
    , m_volume_tolerance(options.volume_tolerance)
{
    const double e_mod = material.youngs_modulus;
    const double nu = material.poisson_ratio;
    if (!(e_mod > 0.0) || !std::isfinite(e_mod))
        throw_error("model: Young's modulus {} must be positive and finite", e_mod);
    if (!(nu >= 0.0 && nu < 0.5))
        throw_error("model: Poisson ratio {} must be in [0, 0.5)", nu);
    if (!(material.density > 0.0) || !std::isfinite(material.density))
        throw_error("model: density {} must be positive and finite", material.density);
    if (!(options.time_step > 0.0) || !std::isfinite(options.time_step))
        throw_error("model: time step {} must be positive and finite", options.time_step);
    if (!(options.volume_tolerance >= 0.0 && options.volume_tolerance < 1.0))
        throw_error("model: volume tolerance {} must be in [0, 1)", options.volume_tolerance);
    const double limit_min = material.strain_limit_min, limit_max = material.strain_limit_max;
    if (!(limit_min >= 0.0 && limit_min <= 1.0 && limit_max >= 1.0))
        throw_error("model: strain limits [{}, {}] must satisfy 0 <= min <= 1 <= max", limit_min,
            limit_max);
    if (!(options.strain_limit_weight_scale >= 0.0)
        || !std::isfinite(options.strain_limit_weight_scale))
        throw_error("model: strain limit weight scale {} must be finite and >= 0",
            options.strain_limit_weight_scale);
    if (!(options.pin_weight_scale > 0.0))
        throw_error("model: pin weight scale {} must be positive", options.pin_weight_scale);
    check_bake(bake);

    const Index n = bake.tet_mesh.num_vertices();
    const Index t = bake.tet_mesh.num_tets();
    const double h2 = options.time_step * options.time_step;

    // Lame parameters -> PD weights per unit volume (see the header).
    const double mu = e_mod / (2.0 * (1.0 + nu));
    const double lambda = e_mod * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    m_strain_weight = 2.0 * mu;
    m_volume_weight = lambda;
    const bool limiting = limit_min > 0.0 || std::isfinite(limit_max);
    m_strain_limit_weight = limiting ? options.strain_limit_weight_scale * m_strain_weight : 0.0;
    const double stiffness = m_strain_weight + m_volume_weight + m_strain_limit_weight;

    m_rest_positions = bake.tet_mesh.positions;
    m_tets = bake.tet_mesh.tets;
    m_dm_inverse = bake.dm_inverse;
    m_rest_volumes = bake.rest_volumes;
    m_masses = material.density * bake.lumped_mass;

    // Node -> (tet, corner) incidence, in increasing 4 * tet + corner order.
    m_incident_indptr = VecXi::Zero(n + 1);
    for (Index e = 0; e < t; ++e)
        for (int c = 0; c < 4; ++c)
            ++m_incident_indptr(m_tets(e, c) + 1);
    for (Index i = 0; i < n; ++i)
        m_incident_indptr(i + 1) += m_incident_indptr(i);
    m_incident_corners.resize(4 * t);
    {
        VecXi fill = m_incident_indptr.head(n);
        for (Index e = 0; e < t; ++e)
            for (int c = 0; c < 4; ++c)
                m_incident_corners(fill(m_tets(e, c))++) = static_cast<int>(4 * e + c);
    }

    // Full-space system A = (2 mu + lambda + w_limit) L + M / h^2 (+ pins below).
    Eigen::SparseMatrix<double> laplacian = bake.laplacian;
    m_full_system = stiffness * laplacian;
    VecX diagonal = m_masses / h2;

    // Pins.
    m_pinned_nodes = options.pinned_nodes;
    const Index num_pins = static_cast<Index>(m_pinned_nodes.size());
    if (options.pin_targets.rows() != 0 && options.pin_targets.rows() != num_pins)
        throw_error("model: {} pin targets given for {} pinned nodes", options.pin_targets.rows(),
            num_pins);
    m_pin_targets.resize(num_pins, 3);
    {
        std::vector<char> seen(n, 0);
        for (Index p = 0; p < num_pins; ++p) {
            const int i = m_pinned_nodes[p];
            if (i < 0 || i >= n)
                throw_error("model: pinned node {} (pin {}) is out of range [0, {})", i, p, n);
            if (seen[i])
                throw_error("model: node {} is pinned twice (pin {})", i, p);
            seen[i] = 1;
            if (options.pin_targets.rows() != 0)
                m_pin_targets.row(p) = options.pin_targets.row(p);
            else
                m_pin_targets.row(p) = m_rest_positions.row(i);
        }
    }
    double largest = 0.0;
    for (Index i = 0; i < n; ++i)
        largest = std::max(largest, m_full_system.coeff(i, i) + diagonal(i));
    m_pin_weight = options.pin_weight_scale * largest;
    for (const int i : m_pinned_nodes)
        diagonal(i) += m_pin_weight;
    for (Index i = 0; i < n; ++i)
        m_full_system.coeffRef(i, i) += diagonal(i);
    m_full_system.makeCompressed();

    m_stiffness_rest = stiffness * (laplacian * m_rest_positions);

    // Reduced system S = B^T A B = (2 mu + lambda + w_limit) B^T L B + density B^T M B / h^2
    //                             + w_p sum_pins B_i^T B_i.
    m_basis = bake.basis;
    m_basis.makeCompressed();
    m_basis_transpose = SparseRowMatrix(m_basis.transpose());
    m_basis_transpose.makeCompressed();
    m_handle_centers = bake.handle_centers;
    m_handle_scales = bake.handle_scales;
    m_handle_column_offsets = bake.handle_column_offsets;
    m_reduced_laplacian = bake.reduced_laplacian;
    MatX reduced = stiffness * bake.reduced_laplacian + (material.density / h2) * bake.reduced_mass;
    for (const int i : m_pinned_nodes) {
        const Eigen::SparseVector<double> row = m_basis.row(i);
        for (Eigen::SparseVector<double>::InnerIterator a(row); a; ++a)
            for (Eigen::SparseVector<double>::InnerIterator b(row); b; ++b)
                reduced(a.index(), b.index()) += m_pin_weight * a.value() * b.value();
    }
    if (!reduced.allFinite())
        throw_error("model: the reduced system matrix has non-finite entries");
    m_reduced_system.compute(reduced);
    if (m_reduced_system.info() != Eigen::Success)
        throw_error("model: the reduced system matrix ({} x {}) is not positive definite",
            reduced.rows(), reduced.cols());
}

} // namespace mat
