#pragma once
// The mutable part of a simulation: where the tet-mesh nodes are and how fast they move.

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"

namespace mat {

struct State {
    MatX3 positions; ///< n x 3
    MatX3 velocities; ///< n x 3

    /// The model's rest positions with zero velocity.
    static State at_rest(const Model& model)
    {
        return State { model.rest_positions(), MatX3::Zero(model.num_nodes(), 3) };
    }
};

} // namespace mat
