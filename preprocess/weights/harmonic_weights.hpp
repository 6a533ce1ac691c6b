#pragma once
// Harmonic skinning weights over the tet mesh (docs/method.md, section 2, step 4), with hard
// constraints, partition of unity, bounds and sparsity.
//
// For each handle j: L w_j = 0 at free nodes, w_j = 1 on handle j's region, 0 on the other
// regions. The constrained nodes are eliminated, the free-free block L_ff is factored ONCE
// (CHOLMOD) and all handles are solved in blocks of columns. Because L 1 = 0 and every
// constrained node belongs to exactly one handle, sum_j w_j = 1 holds up to round-off.
// The linear FEM Laplacian is not an M-matrix on meshes with obtuse dihedral angles, so weights
// can leave [0, 1] by a little: they are clamped. Each node then keeps its K largest weights,
// renormalized to sum to 1 (O(nnz) runtime cost instead of O(#V * m)).

#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"

namespace mat {

struct HarmonicWeightOptions {
    /// K: the largest weights kept per node. 8 by measurement (tests/bench/bake_math_bench.cpp,
    /// ~50k tets, 150 handles, region alpha 0.5): harmonic weights have long tails; K = 8
    /// changes a weight by at most 0.13-0.20 (rms per node 0.08), K = 12 by 0.08-0.13 (0.05),
    /// K = 16 by 0.05-0.08 (0.03), while the runtime's B^T y and B q cost grows linearly with K
    /// (about 0.3 ms each at K = 8 for 10k nodes, single thread). Larger handle regions (alpha)
    /// shorten the tails more cheaply: alpha 0.8 with K = 8 changes weights by 0.07 (rms 0.02).
    int max_handles_per_node = 8;
    /// Right-hand sides solved at once; bounds the dense workspace to #free x block_columns.
    int block_columns = 32;
};

struct HarmonicWeightDiagnostics {
    Index num_free = 0; ///< nodes solved for
    Index num_constrained = 0; ///< nodes in handle regions
    Index factor_nonzeros = 0; ///< nnz of the Cholesky factor of L_ff
    double max_partition_error = 0.0; ///< max_i |sum_j w_ij - 1| of the raw solve
    double min_weight = 0.0; ///< smallest raw weight (slightly < 0 on obtuse meshes)
    double max_weight = 0.0; ///< largest raw weight (slightly > 1 on obtuse meshes)
    double max_clamp_change = 0.0; ///< max |w - w_raw| of the clamp-and-renormalize step
    double max_sparsify_change = 0.0; ///< max |w_sparse - w| over all node/handle pairs
    double rms_sparsify_change = 0.0; ///< sqrt(mean over nodes of ||w_sparse,i - w_i||^2)
    double max_dropped_weight = 0.0; ///< largest weight removed by sparsification
    Index nonzeros = 0; ///< nnz of the output
    double factor_seconds = 0.0;
    double solve_seconds = 0.0; ///< right-hand sides, solves and per-node top-K selection
};

struct HarmonicWeights {
    /// #V x m: per node at most K positive weights summing to 1 (exactly 1 / 0 on regions).
    Eigen::SparseMatrix<double, Eigen::RowMajor> weights;
    HarmonicWeightDiagnostics diagnostics;
};

/// Solves for the weights. `laplacian`  #V x #V (assemble_laplacian: symmetric, L 1 = 0),
/// `region_owner`  #V (assign_handle_regions: handle index or -1 for a free node),
/// `num_handles` = m >= 1, every handle owning at least one node.
/// Throws mat::Error if a handle owns no node, if a group of connected free nodes touches no
/// region (its weights would be undefined), or if L_ff is not positive definite.
HarmonicWeights compute_harmonic_weights(const Eigen::SparseMatrix<double>& laplacian,
    const Eigen::Ref<const VecXi>& region_owner, Index num_handles,
    const HarmonicWeightOptions& options = {});

} // namespace mat
