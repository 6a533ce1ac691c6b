#pragma once
// The pin term: attachment constraints w_p/2 ||x_i - p_i||^2 on the pinned nodes (Bouaziz et al.
// 2014, section 5; docs/method.md, section 3). Its weight and its share of the system matrix
// (w_p on A's diagonal, w_p B_i^T B_i in the reduced S) are the Model's; its share of the global
// step's right-hand side, w_p p_i at each pinned node, is added here once per step. The elastic
// term is apart (runtime/pd/elastic_term.hpp).

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"

namespace mat {

/// rhs_i += w_p p_i for each pinned node i of `model`; `targets`  #pinned x 3 in the model's pin
/// order, `rhs`  n x 3.
void add_pin_term(
    const Model& model, const Eigen::Ref<const MatX3>& targets, Eigen::Ref<MatX3> rhs);

} // namespace mat
