#pragma once
// What --stats and the VTU "stretch" field report about a body: its energies and how far its
// tets are stretched. Not on the step's hot path: computed only for written frames.

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"
#include "runtime/state.hpp"

namespace mat {

struct BodyMeasures {
    double kinetic = 0.0; ///< 1/2 sum m_i |v_i|^2, J
    double potential = 0.0; ///< -sum m_i g . x_i, J (zero at the origin)
    /// The PD elastic energy sum_e vol_e (mu ||F - R||^2 + lambda/2 ||F - P_vol(F)||^2
    /// + w_limit/2 ||F - P_limit(F)||^2), J.
    double elastic = 0.0;
    double max_strain = 0.0; ///< max over tets of max_i |sigma_i - 1| (signed singular values)
    Vec3 momentum = Vec3::Zero(); ///< sum m_i v_i, kg m/s
};

/// Measures `state` of `model` under gravity `gravity`. If `tet_strain` is not null it receives
/// max_i |sigma_i - 1| per tet (T). Parallel over tets; the result does not depend on the
/// thread count.
BodyMeasures measure_body(
    const Model& model, const State& state, const Vec3& gravity, VecX* tet_strain = nullptr);

} // namespace mat
