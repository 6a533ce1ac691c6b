#include "runtime/pd/pin_term.hpp"

#include "common/error.hpp"

namespace mat {

void add_pin_term(const Model& model, const Eigen::Ref<const MatX3>& targets, Eigen::Ref<MatX3> rhs)
{
    const auto& pins = model.pinned_nodes();
    MAT_CHECK(targets.rows() == static_cast<Index>(pins.size()) && rhs.rows() == model.num_nodes(),
        "pin term: {} targets for {} pins, right-hand side of {} rows for {} nodes", targets.rows(),
        pins.size(), rhs.rows(), model.num_nodes());
    for (std::size_t p = 0; p < pins.size(); ++p)
        rhs.row(pins[p]) += model.pin_weight() * targets.row(static_cast<Index>(p));
}

} // namespace mat
