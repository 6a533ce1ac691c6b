#include "preprocess/weights/harmonic_weights.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/sparse_cholesky.hpp"
#include "common/timer.hpp"
#include "common/union_find.hpp"

namespace mat {

namespace {
    void check_every_free_node_reaches_a_region(
        const Eigen::SparseMatrix<double>& laplacian, const Eigen::Ref<const VecXi>& owner)
    {
        const Index n = laplacian.rows();
        UnionFind components(n); // over the graph of the Laplacian's pattern
        for (Index col = 0; col < laplacian.outerSize(); ++col)
            for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, col); it; ++it)
                components.unite(it.row(), it.col());
        std::vector<char> has_region(static_cast<size_t>(n), 0);
        for (Index i = 0; i < n; ++i)
            if (owner[i] >= 0)
                has_region[components.find(i)] = 1;
        for (Index i = 0; i < n; ++i)
            if (owner[i] < 0 && !has_region[components.find(i)])
                throw_error("harmonic weights: tet-mesh node {} is connected to no handle region "
                            "(a mesh component without handles, or a node in no tet)",
                    i);
    }

    // Per free node: running statistics and its K largest clamped weights, sorted descending.
    struct RowStats {
        double sum_raw = 0.0;
        double min_raw = 0.0;
        double max_raw = 0.0;
        double sum_clamped = 0.0;
        double sumsq_clamped = 0.0;
        double max_dropped = 0.0;
        int kept = 0;
    };

    class TopWeights {
    public:
        TopWeights(Index rows, int k)
            : m_k(k)
            , m_values(static_cast<size_t>(rows) * k, 0.0)
            , m_handles(static_cast<size_t>(rows) * k, -1)
            , m_stats(static_cast<size_t>(rows))
        {
        }

        // Records raw weight `raw` of handle `handle` at free node `row`. Handles arrive in
        // increasing order, so on equal values the lower handle index stays first.
        void add(Index row, int handle, double raw)
        {
            RowStats& s = m_stats[row];
            s.sum_raw += raw;
            s.min_raw = std::min(s.min_raw, raw);
            s.max_raw = std::max(s.max_raw, raw);
            const double w = std::clamp(raw, 0.0, 1.0);
            s.sum_clamped += w;
            s.sumsq_clamped += w * w;
            if (w <= 0.0)
                return;
            double* values = &m_values[static_cast<size_t>(row) * m_k];
            int* handles = &m_handles[static_cast<size_t>(row) * m_k];
            if (s.kept == m_k) {
                if (!(w > values[m_k - 1])) {
                    s.max_dropped = std::max(s.max_dropped, w);
                    return;
                }
                s.max_dropped = std::max(s.max_dropped, values[m_k - 1]);
                --s.kept;
            }
            int position = s.kept;
            while (position > 0 && values[position - 1] < w) {
                values[position] = values[position - 1];
                handles[position] = handles[position - 1];
                --position;
            }
            values[position] = w;
            handles[position] = handle;
            ++s.kept;
        }

        int k() const { return m_k; }
        const RowStats& stats(Index row) const { return m_stats[row]; }
        const double* values(Index row) const { return &m_values[static_cast<size_t>(row) * m_k]; }
        const int* handles(Index row) const { return &m_handles[static_cast<size_t>(row) * m_k]; }

    private:
        int m_k;
        std::vector<double> m_values;
        std::vector<int> m_handles;
        std::vector<RowStats> m_stats;
    };

    /// The free nodes (no region), renumbered in order, so the lower triangle of L maps onto
    /// that of L_ff.
    struct FreeNodes {
        std::vector<Index> index; ///< per node: its free index, or -1 in a region
        std::vector<Index> nodes; ///< per free index: its node
    };

    // Numbers the free nodes; checks every owner is a handle or -1 and every region non-empty.
    FreeNodes number_free_nodes(const Eigen::Ref<const VecXi>& region_owner, Index num_handles)
    {
        const Index n = region_owner.size();
        VecXi region_size = VecXi::Zero(num_handles);
        FreeNodes free;
        free.index.assign(static_cast<size_t>(n), -1);
        for (Index i = 0; i < n; ++i) {
            const int owner = region_owner[i];
            if (owner >= num_handles || owner < -1)
                throw_error("harmonic weights: node {} is assigned to handle {} of {}", i, owner,
                    num_handles);
            if (owner >= 0) {
                ++region_size[owner];
            } else {
                free.index[i] = static_cast<Index>(free.nodes.size());
                free.nodes.push_back(i);
            }
        }
        for (Index j = 0; j < num_handles; ++j)
            if (region_size[j] == 0)
                throw_error("harmonic weights: handle {} has an empty region", j);
        return free;
    }

    /// The free-node system: L_ff (lower triangle) and R = -L_fc P, P(c, j) = 1 if constrained
    /// node c is in region j.
    struct FreeSystem {
        Eigen::SparseMatrix<double> lff;
        Eigen::SparseMatrix<double> rhs;
    };

    // Splits L into the free block and the right-hand sides of the constrained nodes.
    FreeSystem assemble_free_system(const Eigen::SparseMatrix<double>& laplacian,
        const Eigen::Ref<const VecXi>& region_owner, const std::vector<Index>& free_index,
        Index num_free, Index num_handles)
    {
        const Index n = laplacian.rows();
        std::vector<Eigen::Triplet<double>> lff_entries;
        std::vector<Eigen::Triplet<double>> rhs_entries;
        lff_entries.reserve(static_cast<size_t>(laplacian.nonZeros() / 2 + n));
        for (Index col = 0; col < laplacian.outerSize(); ++col)
            for (Eigen::SparseMatrix<double>::InnerIterator it(laplacian, col); it; ++it) {
                const Index fi = free_index[it.row()];
                if (fi < 0)
                    continue;
                const Index fj = free_index[col];
                if (fj >= 0) {
                    if (fi >= fj)
                        lff_entries.emplace_back(fi, fj, it.value());
                } else {
                    rhs_entries.emplace_back(fi, region_owner[col], -it.value());
                }
            }
        FreeSystem system;
        system.lff.resize(num_free, num_free);
        system.lff.setFromTriplets(lff_entries.begin(), lff_entries.end());
        lff_entries = {};
        system.rhs.resize(num_free, num_handles);
        system.rhs.setFromTriplets(rhs_entries.begin(), rhs_entries.end());
        rhs_entries = {};
        return system;
    }

    // Factors L_ff once and solves for every handle by blocks of columns, keeping each free
    // node's largest weights in `top`.
    void solve_free_weights(const FreeSystem& system, Index num_free, Index num_handles,
        const HarmonicWeightOptions& options, HarmonicWeightDiagnostics& diag, TopWeights& top)
    {
        Timer timer;
        SparseCholesky cholesky;
        cholesky.compute(system.lff, "harmonic weights: free-node Laplacian L_ff");
        diag.factor_nonzeros = cholesky.factor_nonzeros();
        diag.factor_seconds = timer.seconds();
        logger().debug("harmonic weights: factored L_ff ({} free nodes, nnz(L) = {}, {}) in "
                       "{:.3f} s",
            num_free, diag.factor_nonzeros, cholesky.ordering(), diag.factor_seconds);

        timer.restart();
        MatX block;
        for (Index first = 0; first < num_handles; first += options.block_columns) {
            const Index count = std::min<Index>(options.block_columns, num_handles - first);
            block = MatX(system.rhs.middleCols(first, count));
            cholesky.solve_in_place(block);
            tbb::parallel_for(tbb::blocked_range<Index>(0, num_free, 512),
                [&](const tbb::blocked_range<Index>& range) {
                    for (Index row = range.begin(); row < range.end(); ++row)
                        for (Index c = 0; c < count; ++c)
                            top.add(row, static_cast<int>(first + c), block(row, c));
                });
        }
        diag.solve_seconds = timer.seconds();
    }

    // Diagnostics of the raw solve, the clamp and the sparsification over the free rows.
    // Clamped weights w_c, clamped-and-renormalized w = w_c / s_c, sparse w_k = w_c / s_k on the
    // kept set (s_c, s_k: sums of all / kept clamped weights of the node).
    void measure_rows(
        const TopWeights& top, Index n, Index num_free, HarmonicWeightDiagnostics& diag)
    {
        diag.min_weight = 0.0;
        diag.max_weight = 1.0;
        double sum_sq_change = 0.0;
        Index nonzeros = diag.num_constrained;
        for (Index row = 0; row < num_free; ++row) {
            const RowStats& s = top.stats(row);
            const double* values = top.values(row);
            diag.max_partition_error
                = std::max(diag.max_partition_error, std::abs(s.sum_raw - 1.0));
            diag.min_weight = std::min(diag.min_weight, s.min_raw);
            diag.max_weight = std::max(diag.max_weight, s.max_raw);
            double kept_sum = 0.0;
            double kept_sq = 0.0;
            for (int c = 0; c < s.kept; ++c) {
                kept_sum += values[c];
                kept_sq += values[c] * values[c];
            }
            const double clamped_scale = 1.0 / s.sum_clamped;
            const double kept_scale = 1.0 / kept_sum;
            const double top_clamped = std::min(s.max_raw, 1.0);
            double clamp_change = std::max(-s.min_raw, top_clamped * std::abs(clamped_scale - 1.0));
            if (s.max_raw > 1.0)
                clamp_change = std::max(clamp_change, std::abs(clamped_scale - s.max_raw));
            diag.max_clamp_change = std::max(diag.max_clamp_change, clamp_change);
            const double kept_change = values[0] * (kept_scale - clamped_scale);
            diag.max_sparsify_change = std::max(
                { diag.max_sparsify_change, kept_change, s.max_dropped * clamped_scale });
            diag.max_dropped_weight
                = std::max(diag.max_dropped_weight, s.max_dropped * clamped_scale);
            const double dropped_sq = std::max(0.0, s.sumsq_clamped - kept_sq);
            sum_sq_change += dropped_sq * clamped_scale * clamped_scale
                + kept_sq * (kept_scale - clamped_scale) * (kept_scale - clamped_scale);
            nonzeros += s.kept;
        }
        diag.rms_sparsify_change = n > 0 ? std::sqrt(sum_sq_change / double(n)) : 0.0;
        diag.nonzeros = nonzeros;
    }

    // The output rows: 1 at a region's own handle, else the kept weights renormalized to sum 1.
    void write_weights(const TopWeights& top, const Eigen::Ref<const VecXi>& region_owner,
        const std::vector<Index>& free_index, Index num_handles, Index nonzeros,
        Eigen::SparseMatrix<double, Eigen::RowMajor>& weights)
    {
        const Index n = region_owner.size();
        weights.resize(n, num_handles);
        weights.resizeNonZeros(nonzeros);
        int* outer = weights.outerIndexPtr();
        int* inner = weights.innerIndexPtr();
        double* value = weights.valuePtr();
        Index position = 0;
        std::vector<std::pair<int, double>> entries;
        for (Index i = 0; i < n; ++i) {
            outer[i] = static_cast<int>(position);
            if (region_owner[i] >= 0) {
                inner[position] = region_owner[i];
                value[position++] = 1.0;
                continue;
            }
            const Index row = free_index[i];
            const RowStats& s = top.stats(row);
            entries.clear();
            double kept_sum = 0.0;
            for (int c = 0; c < s.kept; ++c) {
                entries.emplace_back(top.handles(row)[c], top.values(row)[c]);
                kept_sum += top.values(row)[c];
            }
            std::sort(entries.begin(), entries.end());
            for (const auto& [handle, w] : entries) {
                inner[position] = handle;
                value[position++] = w / kept_sum;
            }
        }
        outer[n] = static_cast<int>(position);
    }
} // namespace

HarmonicWeights compute_harmonic_weights(const Eigen::SparseMatrix<double>& laplacian,
    const Eigen::Ref<const VecXi>& region_owner, Index num_handles,
    const HarmonicWeightOptions& options)
{
    const Index n = laplacian.rows();
    MAT_CHECK(laplacian.cols() == n, "Laplacian must be square");
    MAT_CHECK(region_owner.size() == n, "{} region owners for {} nodes", region_owner.size(), n);
    if (num_handles < 1)
        throw_error("harmonic weights: need at least one handle, got {}", num_handles);
    if (options.max_handles_per_node < 1)
        throw_error("harmonic weights: max handles per node must be >= 1, got {}",
            options.max_handles_per_node);
    MAT_CHECK(options.block_columns >= 1, "block_columns must be >= 1");

    const FreeNodes free = number_free_nodes(region_owner, num_handles);
    check_every_free_node_reaches_a_region(laplacian, region_owner);

    HarmonicWeights result;
    HarmonicWeightDiagnostics& diag = result.diagnostics;
    const auto num_free = static_cast<Index>(free.nodes.size());
    diag.num_free = num_free;
    diag.num_constrained = n - num_free;
    const int k = static_cast<int>(std::min<Index>(options.max_handles_per_node, num_handles));
    TopWeights top(num_free, k);
    if (num_free > 0) {
        const FreeSystem system
            = assemble_free_system(laplacian, region_owner, free.index, num_free, num_handles);
        solve_free_weights(system, num_free, num_handles, options, diag, top);
    }

    measure_rows(top, n, num_free, diag);
    write_weights(top, region_owner, free.index, num_handles, diag.nonzeros, result.weights);

    if (diag.max_partition_error > 1e-8)
        logger().warn("harmonic weights: partition of unity holds only to {:.2e} before "
                      "renormalization (ill-conditioned L_ff?)",
            diag.max_partition_error);
    logger().debug("harmonic weights: {} free / {} constrained nodes, raw range [{:.3e}, {:.6f}], "
                   "clamp change {:.2e}, K = {}: sparsify max change {:.2e}, rms {:.2e}",
        diag.num_free, diag.num_constrained, diag.min_weight, diag.max_weight,
        diag.max_clamp_change, k, diag.max_sparsify_change, diag.rms_sparsify_change);
    return result;
}

} // namespace mat
