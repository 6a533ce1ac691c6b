#pragma once
// The projective dynamics energy of an iterate within a time step (Bouaziz et al. 2014, eq. 14;
// docs/method.md, "Accelerated iterations"):
//   E(x) = 1/(2 h^2) ||x - s||_M^2 + sum_e vol_e 1/2 sum_c w_c ||F_e(x) - P_c(F_e(x))||^2
//          + w_p/2 sum_pins ||x_i - p_i||^2,
// the quantity one local-global iteration never increases. The elastic sum comes from the local
// step (LocalStep::set_energy); the inertia and pin terms are here. Sums run in fixed blocks
// added in order: the same result for any thread count.

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"

namespace mat {

/// 1/(2 h^2) sum_i m_i ||x_i - s_i||^2: `positions`, `inertia`  n x 3, h the model's step.
double inertia_energy(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3>& inertia);

/// w_p/2 sum_p ||x_{i_p} - p_p||^2 over the model's pins: `positions`  n x 3, `targets`
/// #pinned x 3.
double pin_energy(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3>& targets);

} // namespace mat
