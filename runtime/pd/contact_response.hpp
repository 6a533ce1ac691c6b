#pragma once
// What the contact stage (runtime/pd/contact_stage.hpp) needs of a body's solver, and nothing
// more: the seam where any global step (reduced, full; a GPU one) plugs into the contact solve.

#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// The compliance D of the contact stage (runtime/pd/contact_stage.hpp): how a force added to a
/// global step's right-hand side moves its kept solution. A force f at node j moves the solution
/// by its response z_j f^T (z_j = S^-1 b_j^T reduced, A^-1 e_j full, a vector of
/// response_size()), and node i by D_ij f with D_ij = apply(i, z_j). The contact stage sees a
/// body's solver only through this interface; each global step implements it for its solution.
class ContactResponse {
public:
    virtual ~ContactResponse() = default;

    /// Length of a response vector (k reduced, n full).
    virtual Index response_size() const = 0;
    /// A new step of contacts: responses kept from earlier steps may be forgotten.
    virtual void begin_contacts() = 0;
    /// z_j, computed the first time it is asked for (and kept for later steps while a budget
    /// allows); the reference stays valid until the next begin_contacts().
    virtual Eigen::Ref<const VecX> node_response(int node) = 0;
    /// Whether the contact stage should take W's entries in node space (from nodal_response()
    /// read at a contact's nodes) rather than along its direction (direction(), response
    /// space), and its points from displaced_positions(): where that is cheaper and the
    /// node-space responses fit the response budget (docs/method.md, "W in node space").
    virtual bool node_space() const = 0;
    /// D's column j in node space: how far every node moves per unit force at node j (n
    /// values, apply(i, z_j) for each node i; a full-space step's is z_j itself). Computed the
    /// first time it is asked for and kept as node_response() is; the reference stays valid until
    /// the next begin_contacts().
    virtual Eigen::Ref<const VecX> nodal_response(int node) = 0;
    /// How far node i moves along a response: the row of node i applied to `response`.
    virtual double apply(int node, const Eigen::Ref<const VecX>& response) const = 0;
    /// Adds `displacement` (response_size() x 3, a sum of responses z f^T: the displacement
    /// of forces f) to the kept solution.
    virtual void add_displacement(const Eigen::Ref<const MatX3>& displacement) = 0;
    /// A point carried by nodes, x = sum_t weights_t x_{nodes_t}, as a sparse row over the
    /// response space: x = offset + sum_i value_i u_i (u the kept solution's rows: q reduced, x
    /// full), and D applied to a response z is sum_i value_i z_i. Appends (index, value) pairs
    /// in the order of the nodes' rows; `slots` (response_size(), all -1) is scratch, returned
    /// all -1.
    virtual void direction(const int* nodes, const double* weights, int count,
        std::vector<int>& index, std::vector<double>& value, Vec3& offset,
        std::vector<int>& slots) const = 0;
    /// The kept solution's rows (u above): coordinate j of row i at
    /// data[i * row_stride + j * column_stride], valid until the solution is replaced.
    struct Rows {
        const double* data = nullptr;
        Index row_stride = 0;
        Index column_stride = 0;
    };
    virtual Rows solution_rows() const = 0;
    /// Every node's position at the kept solution plus `displacement` (response_size() x 3),
    /// into `out`  n x 3 (row-major, contiguous).
    virtual void displaced_positions(
        const Eigen::Ref<const MatX3>& displacement, Eigen::Ref<MatX3> out)
        = 0;
    /// Node i's position in the kept solution.
    virtual Vec3 node_position(int node) const = 0;
};

} // namespace mat
