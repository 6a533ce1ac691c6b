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

    /// Throws if the material or the options are out of range.
    void check_inputs(const Material& material, const ModelOptions& options)
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
            throw_error("model: strain limits [{}, {}] must satisfy 0 <= min <= 1 <= max",
                limit_min, limit_max);
        if (!(options.strain_limit_weight_scale >= 0.0)
            || !std::isfinite(options.strain_limit_weight_scale))
            throw_error("model: strain limit weight scale {} must be finite and >= 0",
                options.strain_limit_weight_scale);
        if (!(options.pin_weight_scale > 0.0))
            throw_error("model: pin weight scale {} must be positive", options.pin_weight_scale);
    }

    /// Node -> (tet, corner) incidence, in increasing 4 * tet + corner order (CSR).
    void node_incidence(const MatX4i& tets, Index n, VecXi& indptr, VecXi& corners)
    {
        const Index t = tets.rows();
        indptr = VecXi::Zero(n + 1);
        for (Index e = 0; e < t; ++e)
            for (int c = 0; c < 4; ++c)
                ++indptr(tets(e, c) + 1);
        for (Index i = 0; i < n; ++i)
            indptr(i + 1) += indptr(i);
        corners.resize(4 * t);
        VecXi fill = indptr.head(n);
        for (Index e = 0; e < t; ++e)
            for (int c = 0; c < 4; ++c)
                corners(fill(tets(e, c))++) = static_cast<int>(4 * e + c);
    }

    /// The pin targets  #pinned x 3 (the given ones, or the rest positions); throws for a pinned
    /// node out of range or pinned twice, or a target count that does not match.
    MatX3 pin_targets_of(const ModelOptions& options, const MatX3& rest)
    {
        const Index n = rest.rows();
        const Index num_pins = static_cast<Index>(options.pinned_nodes.size());
        if (options.pin_targets.rows() != 0 && options.pin_targets.rows() != num_pins)
            throw_error("model: {} pin targets given for {} pinned nodes",
                options.pin_targets.rows(), num_pins);
        MatX3 targets(num_pins, 3);
        std::vector<char> seen(n, 0);
        for (Index p = 0; p < num_pins; ++p) {
            const int i = options.pinned_nodes[p];
            if (i < 0 || i >= n)
                throw_error("model: pinned node {} (pin {}) is out of range [0, {})", i, p, n);
            if (seen[i])
                throw_error("model: node {} is pinned twice (pin {})", i, p);
            seen[i] = 1;
            if (options.pin_targets.rows() != 0)
                targets.row(p) = options.pin_targets.row(p);
            else
                targets.row(p) = rest.row(i);
        }
        return targets;
    }

    /// Adds the diagonal M / h^2 and the pins' weight to `system` (stiffness L_w); returns the
    /// pin weight w_p = scale x the largest diagonal entry of L_w + M / h^2 (see the header).
    double add_mass_and_pins(Eigen::SparseMatrix<double>& system, VecX diagonal,
        const std::vector<int>& pinned, double scale)
    {
        const Index n = system.rows();
        double largest = 0.0;
        for (Index i = 0; i < n; ++i)
            largest = std::max(largest, system.coeff(i, i) + diagonal(i));
        const double pin_weight = scale * largest;
        for (const int i : pinned)
            diagonal(i) += pin_weight;
        for (Index i = 0; i < n; ++i)
            system.coeffRef(i, i) += diagonal(i);
        system.makeCompressed();
        return pin_weight;
    }

    /// S = B^T A B = (2 mu + lambda + w_limit) B^T L B + density B^T M B / h^2 + w_p sum_pins B_i^T
    /// B_i.
    void factor_reduced_system(const BakeData& bake, double stiffness, double mass_scale,
        const SparseRowMatrix& basis, const std::vector<int>& pinned, double pin_weight,
        Eigen::LLT<MatX>& factor)
    {
        MatX reduced = stiffness * bake.reduced_laplacian + mass_scale * bake.reduced_mass;
        for (const int i : pinned) {
            const Eigen::SparseVector<double> row = basis.row(i);
            for (Eigen::SparseVector<double>::InnerIterator a(row); a; ++a)
                for (Eigen::SparseVector<double>::InnerIterator b(row); b; ++b)
                    reduced(a.index(), b.index()) += pin_weight * a.value() * b.value();
        }
        if (!reduced.allFinite())
            throw_error("model: the reduced system matrix has non-finite entries");
        factor.compute(reduced);
        if (factor.info() != Eigen::Success)
            throw_error("model: the reduced system matrix ({} x {}) is not positive definite",
                reduced.rows(), reduced.cols());
    }

} // namespace

Model::Model(const BakeData& bake, const Material& material, const ModelOptions& options)
    : m_material(material)
    , m_time_step(options.time_step)
    , m_volume_tolerance(options.volume_tolerance)
{
    check_inputs(material, options);
    check_bake(bake);

    const Index n = bake.tet_mesh.num_vertices();
    const double h2 = options.time_step * options.time_step;

    // Lame parameters -> PD weights per unit volume (see the header).
    const double e_mod = material.youngs_modulus;
    const double nu = material.poisson_ratio;
    const double mu = e_mod / (2.0 * (1.0 + nu));
    const double lambda = e_mod * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    m_strain_weight = 2.0 * mu;
    m_volume_weight = lambda;
    const bool limiting
        = material.strain_limit_min > 0.0 || std::isfinite(material.strain_limit_max);
    m_strain_limit_weight = limiting ? options.strain_limit_weight_scale * m_strain_weight : 0.0;
    const double stiffness = m_strain_weight + m_volume_weight + m_strain_limit_weight;

    m_rest_positions = bake.tet_mesh.positions;
    m_tets = bake.tet_mesh.tets;
    m_dm_inverse = bake.dm_inverse;
    m_rest_volumes = bake.rest_volumes;
    m_masses = material.density * bake.lumped_mass;
    node_incidence(m_tets, n, m_incident_indptr, m_incident_corners);

    // Full-space system A = (2 mu + lambda + w_limit) L + M / h^2 + pins.
    m_pinned_nodes = options.pinned_nodes;
    m_pin_targets = pin_targets_of(options, m_rest_positions);
    const Eigen::SparseMatrix<double> laplacian = bake.laplacian;
    m_full_system = stiffness * laplacian;
    m_pin_weight
        = add_mass_and_pins(m_full_system, m_masses / h2, m_pinned_nodes, options.pin_weight_scale);
    m_stiffness_rest = stiffness * (laplacian * m_rest_positions);

    m_basis = bake.basis;
    m_basis.makeCompressed();
    m_basis_transpose = SparseRowMatrix(m_basis.transpose());
    m_basis_transpose.makeCompressed();
    m_handle_centers = bake.handle_centers;
    m_handle_scales = bake.handle_scales;
    m_handle_column_offsets = bake.handle_column_offsets;
    m_reduced_laplacian = bake.reduced_laplacian;
    factor_reduced_system(bake, stiffness, material.density / h2, m_basis, m_pinned_nodes,
        m_pin_weight, m_reduced_system);
}

} // namespace mat
