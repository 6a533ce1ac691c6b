#pragma once
// How far a candidate model is from the reference (mat-bake --error), and where its linear
// handles lock.

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"

namespace mat {

/// Distance between two deformed copies of one surface, in % of the bounding-box diagonal.
struct SurfaceError {
    double rms_percent = 0.0;
    double max_percent = 0.0;
};

/// Vertex-to-vertex distances between `a` and `b` (both #Vs x 3, the same surface), relative to
/// `diagonal`.
SurfaceError surface_error(
    const Eigen::Ref<const MatX3>& a, const Eigen::Ref<const MatX3>& b, double diagonal);

/// The local step's residual per handle: r_j = sum_e w_j(e) vol_e ||F_e - R_e||_F^2, with R_e the
/// rotation nearest F_e (the strain constraint's projection, Bouaziz et al. 2014 eq. 6-7) and
/// w_j(e) handle j's weight averaged over the tet's 4 nodes. Where linear handles lock (bending
/// their affine fields cannot follow), the reduced solution keeps strain the local step cannot
/// remove, and r_j is large.  positions  n x 3; returns m.
VecX handle_residuals(const BakeData& bake, const Eigen::Ref<const MatX3>& positions);

} // namespace mat
