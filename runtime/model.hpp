#pragma once
// The immutable simulation model built from a bake (docs/method.md, section 3): material weights,
// masses, pins, and the projective dynamics system matrices for one time step, the reduced one
// prefactored. Knows nothing of files: build it from a BakeData (formats/bake_io reads one).
//
// Material -> PD weights (Bouaziz et al. 2014, sections 4-5; Lame parameters of E and nu):
//   mu = E / (2 (1 + nu)),  lambda = E nu / ((1 + nu)(1 - 2 nu)).
//   Strain (ARAP / corotated) constraint of tet e: w_e/2 ||F - R||_F^2 with w_e = 2 mu vol_e,
//   which is the corotated linear energy mu ||F - R||^2 integrated over the tet.
//   Volume constraint of tet e: w_e/2 ||F - P_vol(F)||_F^2 with w_e = lambda vol_e, where P_vol
//   clamps det F to [1 - eps, 1 + eps]. (A PD approximation: lambda penalizes volume change in
//   linear elasticity; the mapping is exact only for small strain.)
//   Strain limiting (optional, Bouaziz et al. 2014 section 5.1): w_e/2 ||F - U clamp(S, min, max)
//   V^T||_F^2 with F = U S V^T (S signed), w_e = w_limit vol_e, w_limit =
//   strain_limit_weight_scale * 2 mu when limiting is on (strain_limit_min > 0 or
//   strain_limit_max finite), else 0.
//   All weights are proportional to vol_e, so the stiffness matrix is
//   L_w = (2 mu + lambda + w_limit) L with the bake's per-unit Laplacian L = sum_e vol_e G_e^T G_e.
//   Masses: M = density * lumped_mass (diagonal).
//   Pins: attachment constraints w_p/2 ||x_i - p_i||^2 with w_p = pin_weight_scale * the
//   largest diagonal entry of L_w + M/h^2. The pinned node then lags its target by at most
//   about |force on it| / w_p, i.e. a relative error ~ 1 / pin_weight_scale (default 1e8).

#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/SparseCore>

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"

namespace mat {

struct Material {
    double youngs_modulus = 1e5; ///< E, Pa
    double poisson_ratio = 0.3; ///< nu in [0, 0.5)
    double density = 1000.0; ///< kg / m^3
    /// Singular values of F are kept in [min, max] by the strain-limit constraint, which is on
    /// iff min > 0 or max is finite; 0 <= min <= 1 <= max.
    double strain_limit_min = 0.0;
    double strain_limit_max = std::numeric_limits<double>::infinity();
};

struct ModelOptions {
    double time_step = 1.0 / 60.0; ///< h, the system matrices are factored for it
    double volume_tolerance = 0.01; ///< eps: det F is kept in [1 - eps, 1 + eps]
    std::vector<int> pinned_nodes; ///< tet-mesh node indices, distinct
    MatX3 pin_targets; ///< #pinned x 3 target positions (empty = the rest positions)
    double pin_weight_scale = 1e8; ///< w_p relative to the largest diagonal entry
    /// w_limit / (2 mu) when strain limiting is on (Material::strain_limit_*), >= 0.
    double strain_limit_weight_scale = 10.0;
};

class Model {
public:
    /// Builds the model. Throws mat::Error if the material is out of range, the bake's shapes
    /// disagree, a pin index is out of range or repeated, or a factorization fails.
    Model(const BakeData& bake, const Material& material, const ModelOptions& options);

    Index num_nodes() const { return m_rest_positions.rows(); }
    Index num_tets() const { return m_tets.rows(); }
    Index num_columns() const { return m_basis.cols(); }
    double time_step() const { return m_time_step; }
    double volume_tolerance() const { return m_volume_tolerance; }
    const Material& material() const { return m_material; }

    const MatX3& rest_positions() const { return m_rest_positions; } ///< n x 3
    const MatX4i& tets() const { return m_tets; } ///< T x 4
    const MatX& dm_inverse() const { return m_dm_inverse; } ///< T x 9 row-major Dm^-1
    const VecX& rest_volumes() const { return m_rest_volumes; } ///< T
    const VecX& masses() const { return m_masses; } ///< n, kg
    double strain_weight() const { return m_strain_weight; } ///< 2 mu (per unit volume)
    double volume_weight() const { return m_volume_weight; } ///< lambda (per unit volume)
    /// w_limit (per unit volume): 0 unless strain limiting is on.
    double strain_limit_weight() const { return m_strain_limit_weight; }

    /// Node -> incident (tet, corner) pairs, CSR: entries [indptr(i), indptr(i+1)) of
    /// incident_corners hold 4 * tet + corner, sorted (a fixed order for deterministic sums).
    const VecXi& incident_indptr() const { return m_incident_indptr; } ///< n + 1
    const VecXi& incident_corners() const { return m_incident_corners; }

    const std::vector<int>& pinned_nodes() const { return m_pinned_nodes; }
    const MatX3& pin_targets() const { return m_pin_targets; } ///< #pinned x 3
    double pin_weight() const { return m_pin_weight; }

    /// L_w X: the stiffness matrix times the rest positions  n x 3 (constant).
    const MatX3& stiffness_rest() const { return m_stiffness_rest; }

    const SparseRowMatrix& basis() const { return m_basis; } ///< B  n x k
    const SparseRowMatrix& basis_transpose() const { return m_basis_transpose; } ///< B^T  k x n
    /// The bake's handles (empty when it has none): centers  m x 3, scales  m, column offsets
    /// m + 1 (handle j owns basis columns [off_j, off_j+1)).
    const MatX3& handle_centers() const { return m_handle_centers; }
    const VecX& handle_scales() const { return m_handle_scales; }
    const VecXi& handle_column_offsets() const { return m_handle_column_offsets; }
    /// B^T L B  k x k: the reduced per-unit Laplacian (L = sum_e vol_e G_e^T G_e).
    const MatX& reduced_laplacian() const { return m_reduced_laplacian; }
    /// S = B^T (L_w + M/h^2 + P) B  k x k, factored (dense LLT).
    const Eigen::LLT<MatX>& reduced_system() const { return m_reduced_system; }
    /// A = L_w + M/h^2 + P  n x n, symmetric, stored full (the full solver factors it).
    const Eigen::SparseMatrix<double>& full_system() const { return m_full_system; }

private:
    Material m_material;
    double m_time_step = 0.0;
    double m_volume_tolerance = 0.0;
    double m_strain_weight = 0.0;
    double m_volume_weight = 0.0;
    double m_strain_limit_weight = 0.0;
    MatX3 m_rest_positions;
    MatX4i m_tets;
    MatX m_dm_inverse;
    VecX m_rest_volumes;
    VecX m_masses;
    VecXi m_incident_indptr;
    VecXi m_incident_corners;
    std::vector<int> m_pinned_nodes;
    MatX3 m_pin_targets;
    double m_pin_weight = 0.0;
    MatX3 m_stiffness_rest;
    SparseRowMatrix m_basis;
    SparseRowMatrix m_basis_transpose;
    MatX3 m_handle_centers;
    VecX m_handle_scales;
    VecXi m_handle_column_offsets;
    MatX m_reduced_laplacian;
    Eigen::LLT<MatX> m_reduced_system;
    Eigen::SparseMatrix<double> m_full_system;
};

} // namespace mat
