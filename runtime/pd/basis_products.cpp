#include "runtime/pd/basis_products.hpp"

#include <algorithm>
#include <cmath>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/handle_monomials.hpp"

namespace mat {

namespace {

    /// Entries of B that the handle form reproduces to this relative accuracy (the bake
    /// divides by s_j where the runtime multiplies by 1 / s_j).
    constexpr double form_tolerance = 1e-12;

    /// acc[0 .. 12) = sum_e weights[e] rows[Stride handles[e] + 0 .. 12), rows 64-byte aligned
    /// with Stride 16 (acc too): one 8-wide and one 4-wide multiply-add per entry with AVX-512.
    template <int Stride>
    inline void sum_rows(
        const double* rows, const int* handles, const double* weights, int count, double* acc)
    {
        static_assert(Stride == 16, "rows of 12 values padded to 16");
#if defined(__AVX512F__)
        __m512d a0 = _mm512_setzero_pd();
        __m256d a1 = _mm256_setzero_pd();
        for (int e = 0; e < count; ++e) {
            const double* row = rows + Stride * handles[e];
            const __m512d w8 = _mm512_set1_pd(weights[e]);
            a0 = _mm512_fmadd_pd(w8, _mm512_load_pd(row), a0);
            a1 = _mm256_fmadd_pd(_mm512_castpd512_pd256(w8), _mm256_load_pd(row + 8), a1);
        }
        _mm512_store_pd(acc, a0);
        _mm256_store_pd(acc + 8, a1);
#else
        for (int v = 0; v < 12; ++v)
            acc[v] = 0.0;
        for (int e = 0; e < count; ++e) {
            const double* row = rows + Stride * handles[e];
            for (int v = 0; v < 12; ++v)
                acc[v] += weights[e] * row[v];
        }
#endif
    }

    /// rows[Stride handles[e] + 0 .. 12) += weights[e] terms[0 .. 12) for each entry e; rows
    /// and terms 64-byte aligned with Stride 16: one 8-wide and one 4-wide multiply-add each.
    template <int Stride>
    inline void add_to_rows(
        const double* terms, const int* handles, const double* weights, int count, double* rows)
    {
        static_assert(Stride == 16, "rows of 12 values padded to 16");
#if defined(__AVX512F__)
        const __m512d t0 = _mm512_load_pd(terms);
        const __m256d t1 = _mm256_load_pd(terms + 8);
        for (int e = 0; e < count; ++e) {
            double* row = rows + Stride * handles[e];
            const __m512d w8 = _mm512_set1_pd(weights[e]);
            _mm512_store_pd(row, _mm512_fmadd_pd(w8, t0, _mm512_load_pd(row)));
            _mm256_store_pd(
                row + 8, _mm256_fmadd_pd(_mm512_castpd512_pd256(w8), t1, _mm256_load_pd(row + 8)));
        }
#else
        for (int e = 0; e < count; ++e) {
            double* row = rows + Stride * handles[e];
            for (int v = 0; v < 12; ++v)
                row[v] += weights[e] * terms[v];
        }
#endif
    }

} // namespace

BasisProducts::BasisProducts(const Model& model)
    : m_model(model)
{
    const SparseRowMatrix& b = model.basis();
    const MatX3& centers = model.handle_centers();
    const VecX& scales = model.handle_scales();
    const VecXi& offsets = model.handle_column_offsets();
    const Index n = b.rows(), k = b.cols(), m = centers.rows();
    if (m == 0 || scales.size() != m || offsets.size() != m + 1 || offsets(0) != 0
        || offsets(m) != k)
        return;
    std::vector<int> column_handle(k, -1);
    m_handles.resize(m);
    for (Index j = 0; j < m; ++j) {
        const int terms = offsets(j + 1) - offsets(j);
        if ((terms != linear_handle_terms && terms != quadratic_handle_terms) || !(scales(j) > 0.0))
            return;
        Handle& h = m_handles[j];
        for (int d = 0; d < 3; ++d)
            h.center[d] = centers(j, d);
        h.inverse_scale = 1.0 / scales(j);
        h.offset = offsets(j);
        h.terms = terms;
        for (int c = offsets(j); c < offsets(j + 1); ++c)
            column_handle[c] = static_cast<int>(j);
    }

    // Every row must be whole handles, each w_ij p_t(y_ij) in term order.
    const int* indptr = b.outerIndexPtr();
    const int* indices = b.innerIndexPtr();
    const double* values = b.valuePtr();
    const double* rest = model.rest_positions().data();
    m_node_offsets.assign(n + 1, 0);
    for (Index i = 0; i < n; ++i) {
        int e = indptr[i];
        while (e < indptr[i + 1]) {
            const int j = column_handle[indices[e]];
            const Handle& h = m_handles[j];
            if (indices[e] != h.offset || e + h.terms > indptr[i + 1])
                return;
            double p[quadratic_handle_terms];
            handle_monomials((rest[3 * i] - h.center[0]) * h.inverse_scale,
                (rest[3 * i + 1] - h.center[1]) * h.inverse_scale,
                (rest[3 * i + 2] - h.center[2]) * h.inverse_scale, p);
            const double w = values[e];
            for (int t = 0; t < h.terms; ++t) {
                const double expected = w * p[t];
                if (indices[e + t] != h.offset + t
                    || !(std::abs(values[e + t] - expected)
                        <= form_tolerance * std::abs(w) * std::max(1.0, std::abs(p[t]))))
                    return;
            }
            if (w != 0.0) {
                m_node_handles.push_back(j);
                m_node_weights.push_back(w);
            }
            e += h.terms;
        }
        m_node_offsets[i + 1] = static_cast<int>(m_node_handles.size());
    }
    // The products' origin: the rest centroid (d_i = X_i - o stays small, so that the
    // handles' polynomials rewritten in d lose few digits to cancellation).
    double origin[3] = { 0.0, 0.0, 0.0 };
    for (Index i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            origin[c] += rest[3 * i + c] / static_cast<double>(n);
    m_rest_offsets.resize(3 * n);
    for (Index i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            m_rest_offsets[3 * i + c] = rest[3 * i + c] - origin[c];
    for (Handle& h : m_handles)
        for (int c = 0; c < 3; ++c)
            h.shift[c] = h.center[c] - origin[c];
    m_node_quadratic.assign(n, 0);
    for (Index i = 0; i < n; ++i)
        for (int e = m_node_offsets[i]; e < m_node_offsets[i + 1]; ++e)
            if (m_handles[m_node_handles[e]].terms == quadratic_handle_terms)
                m_node_quadratic[i] = 1;
    m_affine_terms.assign(affine_stride * m, 0.0);
    m_any_quadratic = std::any_of(m_handles.begin(), m_handles.end(),
        [](const Handle& h) { return h.terms == quadratic_handle_terms; });
    m_chunk_rows.assign(static_cast<std::size_t>(transpose_chunks) * affine_stride * m, 0.0);
    m_chunk_quadratic_rows.assign(
        m_any_quadratic ? static_cast<std::size_t>(transpose_chunks) * quadratic_stride * m : 0,
        0.0);
    m_quadratic_terms.assign(quadratic_stride * m, 0.0);
    m_factored = true;
}

void BasisProducts::transpose_times(const double* y, double* out)
{
    if (!m_factored) {
        const SparseRowMatrix& bt = m_model.basis_transpose();
        const int* indptr = bt.outerIndexPtr();
        const int* indices = bt.innerIndexPtr();
        const double* values = bt.valuePtr();
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, bt.rows(), 16), [&](const tbb::blocked_range<Index>& r) {
                for (Index a = r.begin(); a != r.end(); ++a) {
                    double acc0 = 0.0, acc1 = 0.0, acc2 = 0.0;
                    for (int j = indptr[a]; j < indptr[a + 1]; ++j) {
                        const double w = values[j];
                        const double* yi = y + 3 * indices[j];
                        acc0 += w * yi[0];
                        acc1 += w * yi[1];
                        acc2 += w * yi[2];
                    }
                    out[3 * a] = acc0;
                    out[3 * a + 1] = acc1;
                    out[3 * a + 2] = acc2;
                }
            });
        return;
    }
    transpose_times_rows(
        [y](Index i, double(&v)[3]) {
            v[0] = y[3 * i];
            v[1] = y[3 * i + 1];
            v[2] = y[3 * i + 2];
        },
        out);
}

void BasisProducts::transpose_times(const LocalSums& y, double* out)
{
    if (!m_factored) {
        // The CSR loops read each node once per column: write y out first.
        const Index n = m_model.num_nodes();
        m_rows.resize(n, 3);
        tbb::parallel_for(tbb::blocked_range<Index>(0, n, 1024), [&](const auto& range) {
            for (Index i = range.begin(); i != range.end(); ++i) {
                double v[3];
                y.row(i, v);
                m_rows.row(i) << v[0], v[1], v[2];
            }
        });
        transpose_times(m_rows.data(), out);
        return;
    }
    transpose_times_rows([&y](Index i, double(&v)[3]) { y.row(i, v); }, out);
}

template <typename Row> void BasisProducts::transpose_times_rows(const Row& row, double* out)
{
    // Column off_j + t of B^T y = sum_i w_ij p_t((d_i - delta_j) sigma_j) y_i (d_i = X_i - o,
    // delta_j = c_j - o, o the rest centroid): expanded in the monomials of d, handle j needs
    // S_j = sum_i w_ij [y_i, d_i (x) y_i] (12 values; 18 more, d_a d_b y_i, for a quadratic
    // handle). Node by node: each node's 12 values are formed once, in registers, and added
    // into the rows of its handles (in L1). The nodes are split into a fixed number of chunks,
    // each with rows of its own, summed in chunk order: the same bits for any thread count.
    const Index m = static_cast<Index>(m_handles.size());
    const Index n = m_model.num_nodes();
    const double* d = m_rest_offsets.data();
    const int chunks = transpose_chunks;
    tbb::parallel_for(tbb::blocked_range<int>(0, chunks, 1), [&](const tbb::blocked_range<int>& r) {
        for (int c = r.begin(); c != r.end(); ++c) {
            double* rows = m_chunk_rows.data() + static_cast<std::size_t>(c) * affine_stride * m;
            double* rows2 = m_chunk_quadratic_rows.data()
                + static_cast<std::size_t>(c) * quadratic_stride * m;
            std::fill(rows, rows + affine_stride * m, 0.0);
            if (m_any_quadratic)
                std::fill(rows2, rows2 + quadratic_stride * m, 0.0);
            const Index first = c * n / chunks, last = (c + 1) * n / chunks;
            for (Index i = first; i < last; ++i) {
                double yi[3];
                row(i, yi);
                const double* di = d + 3 * i;
                alignas(64) double terms[affine_stride] = { yi[0], yi[1], yi[2], di[0] * yi[0],
                    di[0] * yi[1], di[0] * yi[2], di[1] * yi[0], di[1] * yi[1], di[1] * yi[2],
                    di[2] * yi[0], di[2] * yi[1], di[2] * yi[2], 0.0, 0.0, 0.0, 0.0 };
                const int begin = m_node_offsets[i], end = m_node_offsets[i + 1];
                add_to_rows<affine_stride>(terms, m_node_handles.data() + begin,
                    m_node_weights.data() + begin, end - begin, rows);
                if (!m_node_quadratic[i])
                    continue;
                double terms2[quadratic_stride];
                for (int k = 0; k < 6; ++k)
                    for (int t = 0; t < 3; ++t)
                        terms2[3 * k + t] = di[quadratic_monomial_first[k]]
                            * di[quadratic_monomial_second[k]] * yi[t];
                for (int e = begin; e < end; ++e) {
                    const int j = m_node_handles[e];
                    if (m_handles[j].terms != quadratic_handle_terms)
                        continue;
                    double* row = rows2 + quadratic_stride * j;
                    for (int v = 0; v < quadratic_stride; ++v)
                        row[v] += m_node_weights[e] * terms2[v];
                }
            }
        }
    });
    tbb::parallel_for(tbb::blocked_range<Index>(0, m, 16), [&](const tbb::blocked_range<Index>& r) {
        for (Index j = r.begin(); j != r.end(); ++j) {
            const Handle& h = m_handles[j];
            double sums[affine_stride] = {}, sums2[quadratic_stride] = {};
            for (int c = 0; c < chunks; ++c) {
                const double* row
                    = m_chunk_rows.data() + (static_cast<std::size_t>(c) * m + j) * affine_stride;
                for (int v = 0; v < 12; ++v)
                    sums[v] += row[v];
                if (h.terms != quadratic_handle_terms)
                    continue;
                const double* row2 = m_chunk_quadratic_rows.data()
                    + (static_cast<std::size_t>(c) * m + j) * quadratic_stride;
                for (int v = 0; v < quadratic_stride; ++v)
                    sums2[v] += row2[v];
            }
            // Back to the handle's monomials of (d - delta) sigma.
            const double sigma = h.inverse_scale;
            const double* delta = h.shift;
            double* o = out + 3 * h.offset;
            for (int t = 0; t < 3; ++t) {
                const double s0 = sums[t];
                o[t] = s0;
                for (int a = 0; a < 3; ++a)
                    o[3 * (1 + a) + t] = sigma * (sums[3 + 3 * a + t] - delta[a] * s0);
                if (h.terms != quadratic_handle_terms)
                    continue;
                for (int k = 0; k < 6; ++k) {
                    const int a = quadratic_monomial_first[k], b = quadratic_monomial_second[k];
                    o[3 * (4 + k) + t] = sigma * sigma
                        * (sums2[3 * k + t] - delta[a] * sums[3 + 3 * b + t]
                            - delta[b] * sums[3 + 3 * a + t] + delta[a] * delta[b] * s0);
                }
            }
        }
    });
}

void BasisProducts::reconstruct(const double* q, double* x)
{
    const double* rest = m_model.rest_positions().data();
    const Index n = m_model.num_nodes();
    if (!m_factored) {
        const SparseRowMatrix& basis = m_model.basis();
        const int* indptr = basis.outerIndexPtr();
        const int* indices = basis.innerIndexPtr();
        const double* values = basis.valuePtr();
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, n, 256), [&](const tbb::blocked_range<Index>& r) {
                for (Index i = r.begin(); i != r.end(); ++i) {
                    double acc0 = rest[3 * i], acc1 = rest[3 * i + 1], acc2 = rest[3 * i + 2];
                    for (int j = indptr[i]; j < indptr[i + 1]; ++j) {
                        const double w = values[j];
                        const double* qa = q + 3 * indices[j];
                        acc0 += w * qa[0];
                        acc1 += w * qa[1];
                        acc2 += w * qa[2];
                    }
                    x[3 * i] = acc0;
                    x[3 * i + 1] = acc1;
                    x[3 * i + 2] = acc2;
                }
            });
        return;
    }
    // x_i = X_i + sum_j w_ij sum_t p_t((d_i - delta_j) sigma_j) q_(off_j + t), with d_i = X_i - o
    // (o the rest centroid) and delta_j = c_j - o: each handle's polynomial is first rewritten
    // in the monomials of d (its affine part g_j: 12 values; 18 more for a quadratic handle),
    // then each node sums w_ij g_j over its handles (whole vector registers, g in L1) and
    // evaluates the sum at d_i once.
    const Index m = static_cast<Index>(m_handles.size());
    double* g = m_affine_terms.data();
    double* g2 = m_quadratic_terms.data();
    for (Index j = 0; j < m; ++j) {
        const Handle& h = m_handles[j];
        const double sigma = h.inverse_scale;
        const double* delta = h.shift;
        const double* qh = q + 3 * h.offset;
        double* gj = g + affine_stride * j;
        double* g2j = g2 + quadratic_stride * j;
        for (int c = 0; c < 3; ++c) {
            double constant = qh[c];
            for (int a = 0; a < 3; ++a) {
                const double qa = qh[3 * (1 + a) + c];
                gj[3 + 3 * a + c] = sigma * qa;
                constant -= sigma * delta[a] * qa;
            }
            if (h.terms == quadratic_handle_terms)
                for (int k = 0; k < 6; ++k) {
                    // sigma^2 (d_a - delta_a)(d_b - delta_b) q_(4 + k).
                    const int a = quadratic_monomial_first[k], b = quadratic_monomial_second[k];
                    const double qk = sigma * sigma * qh[3 * (4 + k) + c];
                    g2j[3 * k + c] = qk;
                    gj[3 + 3 * a + c] -= delta[b] * qk;
                    gj[3 + 3 * b + c] -= delta[a] * qk;
                    constant += delta[a] * delta[b] * qk;
                }
            gj[c] = constant;
        }
    }
    const double* d = m_rest_offsets.data();
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, n, 256), [&](const tbb::blocked_range<Index>& r) {
            for (Index i = r.begin(); i != r.end(); ++i) {
                alignas(64) double acc[affine_stride];
                const int begin = m_node_offsets[i], end = m_node_offsets[i + 1];
                sum_rows<affine_stride>(g, m_node_handles.data() + begin,
                    m_node_weights.data() + begin, end - begin, acc);
                const double* di = d + 3 * i;
                double out[3];
                for (int c = 0; c < 3; ++c)
                    out[c] = rest[3 * i + c] + acc[c] + acc[3 + c] * di[0] + acc[6 + c] * di[1]
                        + acc[9 + c] * di[2];
                if (m_node_quadratic[i]) {
                    double acc2[quadratic_stride] = {};
                    for (int e = begin; e < end; ++e) {
                        const int j = m_node_handles[e];
                        if (m_handles[j].terms != quadratic_handle_terms)
                            continue;
                        const double w = m_node_weights[e];
                        for (int v = 0; v < quadratic_stride; ++v)
                            acc2[v] += w * g2[quadratic_stride * j + v];
                    }
                    double mono[quadratic_handle_terms];
                    handle_monomials(di[0], di[1], di[2], mono);
                    for (int c = 0; c < 3; ++c)
                        for (int k = 0; k < 6; ++k)
                            out[c] += acc2[3 * k + c] * mono[4 + k];
                }
                x[3 * i] = out[0];
                x[3 * i + 1] = out[1];
                x[3 * i + 2] = out[2];
            }
        });
}

} // namespace mat
