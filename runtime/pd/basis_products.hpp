#pragma once
// The two products of the reduced global step with the handle basis B (n x k), once per PD
// iteration: B^T y (the reduced right-hand side) and X + B q (the positions).
//
// A bake's B has handle form (preprocess/basis/handle_basis.hpp): handle j owns the columns
// [off_j, off_j+1), and B(i, off_j + t) = w_ij p_t(y_ij) with y_ij = (X_i - c_j) / s_j and p_t
// the t-th monomial (common/handle_monomials.hpp: 1, y1, y2, y3 for a linear handle, plus the six
// quadratic ones). Then one weight per (node, handle) stands for 4 or 10 entries. Both products
// work in the monomials of d_i = X_i - o (o the rest centroid), where a handle's polynomial is a
// few coefficients:
// B^T y forms each node's terms [y_i, d_i (x) y_i] once and adds them, weighted, into its
// handles' sums (then one shift per handle back to its own monomials); X + B q rewrites each
// handle's polynomial in d once per call and sums, per node, its handles' coefficients. Each
// (node, handle) entry is then 12 multiply-adds on data in L1 (30 for a quadratic handle), one
// weight and one index instead of 4 or 10 values and indices. When the basis does not
// have that form exactly (checked entry by entry at construction; e.g. a test's identity
// basis), the products fall back to plain CSR loops. Either way the summation order is fixed,
// so the results do not depend on the thread count.

#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/local_step.hpp"

namespace mat {

class BasisProducts {
public:
    explicit BasisProducts(const Model& model);

    /// True when the handle form is used (else the CSR fallback).
    bool factored() const { return m_factored; }

    /// out = B^T y: `y`  n x 3 row-major (3 n doubles), `out`  k x 3 row-major (3 k doubles).
    /// Not for concurrent calls on one object (it keeps a workspace).
    void transpose_times(const double* y, double* out);
    /// The same with y read row by row from the local step's sums (y = base + the slot sums, see
    /// LocalSums): the right-hand side is never written out.
    void transpose_times(const LocalSums& y, double* out);
    /// The handle form's nonzero entries, node by node (only when factored()): node i has the
    /// entries [node_offsets()[i], node_offsets()[i + 1]) of node_handles() (handle indices,
    /// ascending) and node_weights() (w_ij).
    const std::vector<int>& node_offsets() const { return m_node_offsets; }
    const std::vector<int>& node_handles() const { return m_node_handles; }
    const std::vector<double>& node_weights() const { return m_node_weights; }
    /// x = X + B q: `q`  k x 3 row-major, `x`  n x 3 row-major.
    /// Not for concurrent calls on one object (it keeps a workspace).
    void reconstruct(const double* q, double* x);

private:
    const Model& m_model;
    bool m_factored = false;
    // Handle form.
    struct Handle {
        double center[3];
        double shift[3]; ///< center minus the rest centroid
        double inverse_scale;
        int offset; ///< first basis column
        int terms; ///< 4 or 10
    };
    std::vector<Handle> m_handles; ///< m
    std::vector<int> m_node_offsets; ///< n + 1: node i's (handle, weight) entries
    std::vector<int> m_node_handles;
    std::vector<double> m_node_weights;
    // Both products: d_i = X_i - (rest centroid), n x 3, and whether node i has weight from a
    // quadratic handle. The reconstruction's workspace: per handle its polynomial's coefficients
    // in the monomials of d, refilled by each call (the affine 12 padded to 16 and aligned,
    // then the quadratic 18).
    static constexpr int affine_stride = 16;
    static constexpr int quadratic_stride = 18;
    std::vector<double> m_rest_offsets;
    std::vector<char> m_node_quadratic;
    std::vector<double, Eigen::aligned_allocator<double>> m_affine_terms;
    std::vector<double> m_quadratic_terms;
    // B^T y's workspace: per chunk of nodes, per handle, its sums (as m_affine_terms and
    // m_quadratic_terms). A fixed number of chunks: the parallel unit, whatever the threads.
    static constexpr int transpose_chunks = 16;
    bool m_any_quadratic = false;
    std::vector<double, Eigen::aligned_allocator<double>> m_chunk_rows;
    std::vector<double> m_chunk_quadratic_rows;
    MatX3 m_rows; ///< the CSR fallback's y, when given as LocalSums

    /// out = B^T y with row(i, v) writing y_i into v.
    template <typename Row> void transpose_times_rows(const Row& row, double* out);
};

} // namespace mat
