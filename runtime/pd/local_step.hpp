#pragma once
// The projective dynamics local step in full space (Bouaziz et al. 2014, section 3; METHOD.md
// section 3): every tet's deformation gradient is projected onto the strain constraint (nearest
// rotation), the volume constraint (det F clamped) and the strain limit (singular values
// clamped), and the projections are gathered into the global step's right-hand side
// sum_e w_e G_e^T P_e^T. The step uses the vectorized kernel of projection_kernel.hpp;
// project_tet is the exact scalar reference it is tested against.

#include <limits>

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"

namespace mat {

/// The projections of one deformation gradient.
struct TetProjection {
    Mat3 rotation; ///< nearest rotation to F (det +1, also for inverted F)
    Mat3 volume; ///< nearest matrix to F with det in [1 - eps, 1 + eps] (F itself if inside)
    Mat3 limit; ///< U clamp(S, min, max) V^T, S signed (F itself if S is inside)
};

/// F = Ds Dm^-1 of tet `tet`. `positions`  n x 3, `tets`  T x 4, `dm_inverse`  T x 9 row-major.
Mat3 deformation_gradient(const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX4i>& tets, const MatX& dm_inverse, Index tet);

/// Projects F (Bouaziz et al. 2014, eq. 19 for the rotation; section 5.2 for the volume):
/// F = U S V^T with U, V rotations and S signed (an inverted F gets its smallest singular value
/// negated); rotation = U V^T; volume = U D V^T, D the point nearest S with prod D = clamp(det F,
/// 1 - eps, 1 + eps) (Newton on its KKT
/// conditions from a feasible start, then made exact); limit = U clamp(S, min, max) V^T.
TetProjection project_tet(const Mat3& deformation_gradient, double volume_tolerance,
    double strain_limit_min = 0.0,
    double strain_limit_max = std::numeric_limits<double>::infinity());

/// Preallocated storage for the local step of one model: a step allocates nothing.
class LocalStep {
public:
    explicit LocalStep(const Model& model);

    /// Computes rhs = sum_e vol_e G_e^T (2 mu R_e + lambda V_e + w_limit L_e)^T  n x 3 at
    /// `positions`  n x 3 (the weighted constraint projections, Bouaziz et al. 2014 eq. 13
    /// right-hand side). Parallel over fixed blocks of consecutive tets, then a per-node gather
    /// in a fixed order: the result does not depend on the thread count. `rhs` must be n x 3.
    void compute(
        const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs);

private:
    /// T x 12: per tet, the 4 x 3 contribution (one row of 3 per corner).
    Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor> m_contributions;
};

} // namespace mat
