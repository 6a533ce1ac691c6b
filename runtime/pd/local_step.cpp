#include "runtime/pd/local_step.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include <Eigen/LU> // Matrix3d::inverse
#include <Eigen/SVD>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "runtime/pd/elastic_term.hpp"

namespace mat {

namespace {
    /// Chunks: about this many blocks each, and at most this many (enough for load balance on
    /// a few threads; each chunk boundary duplicates the slots of the nodes it cuts).
    constexpr Index blocks_per_chunk = 48;
    constexpr Index max_chunks = 64;
    constexpr std::size_t slot_stride = local_slot_stride;

    /// p[c][k][l] = x[3 nodes[c][l] + k]: the corner positions of a block's tets, lanes
    /// contiguous. With AVX-512, one 8-lane gather per corner, coordinate and half block:
    /// scalar loads would be stored one lane at a time and then read back as vectors, which
    /// stalls on store forwarding.
    template <typename BlockT>
    inline void gather_corners(
        const BlockT& block, const double* x, double (&p)[4][3][projection_lanes])
    {
#if defined(__AVX512F__)
        static_assert(projection_lanes % 8 == 0, "gathers of 8 lanes");
        for (int c = 0; c < 4; ++c)
            for (int h = 0; h < projection_lanes; h += 8) {
                const __m256i node
                    = _mm256_load_si256(reinterpret_cast<const __m256i*>(&block.nodes[c][h]));
                const __m256i row = _mm256_add_epi32(_mm256_add_epi32(node, node), node);
                _mm512_store_pd(&p[c][0][h], _mm512_i32gather_pd(row, x, 8));
                _mm512_store_pd(&p[c][1][h], _mm512_i32gather_pd(row, x + 1, 8));
                _mm512_store_pd(&p[c][2][h], _mm512_i32gather_pd(row, x + 2, 8));
            }
#else
        for (int l = 0; l < projection_lanes; ++l)
            for (int c = 0; c < 4; ++c) {
                const double* xc = x + 3 * block.nodes[c][l];
                p[c][0][l] = xc[0];
                p[c][1][l] = xc[1];
                p[c][2][l] = xc[2];
            }
#endif
    }

    /// slot += share for every corner of the block's lanes, one 4-double slot per node (x, y, z,
    /// unused). Padding lanes add zeros (their volume is 0) to lane 0's slots. With AVX-512 the
    /// shares are transposed in registers to one 4-double vector per corner and lane, and each
    /// corner costs one load, add and store.
    template <typename BlockT>
    inline void scatter_shares(
        const BlockT& block, const double (&share)[4][3][projection_lanes], double* slot_sums)
    {
#if defined(__AVX512F__)
        const __m512i low_pairs = _mm512_set_epi64(11, 10, 3, 2, 9, 8, 1, 0);
        const __m512i high_pairs = _mm512_set_epi64(15, 14, 7, 6, 13, 12, 5, 4);
        const __m512d zero = _mm512_setzero_pd();
        const auto add = [&](int slot, __m256d value) {
            double* o = slot_sums + slot_stride * slot;
            _mm256_storeu_pd(o, _mm256_add_pd(_mm256_loadu_pd(o), value));
        };
        for (int k = 0; k < 4; ++k)
            for (int h = 0; h < projection_lanes; h += 8) {
                const __m512d x = _mm512_load_pd(&share[k][0][h]);
                const __m512d y = _mm512_load_pd(&share[k][1][h]);
                const __m512d z = _mm512_load_pd(&share[k][2][h]);
                const __m512d xy_even = _mm512_unpacklo_pd(x, y); // x0 y0 x2 y2 x4 y4 x6 y6
                const __m512d xy_odd = _mm512_unpackhi_pd(x, y);
                const __m512d z_even = _mm512_unpacklo_pd(z, zero); // z0 0 z2 0 ...
                const __m512d z_odd = _mm512_unpackhi_pd(z, zero);
                const __m512d l02 = _mm512_permutex2var_pd(xy_even, low_pairs, z_even);
                const __m512d l46 = _mm512_permutex2var_pd(xy_even, high_pairs, z_even);
                const __m512d l13 = _mm512_permutex2var_pd(xy_odd, low_pairs, z_odd);
                const __m512d l57 = _mm512_permutex2var_pd(xy_odd, high_pairs, z_odd);
                const int* slot = &block.slots[k][h];
                add(slot[0], _mm512_castpd512_pd256(l02));
                add(slot[1], _mm512_castpd512_pd256(l13));
                add(slot[2], _mm512_extractf64x4_pd(l02, 1));
                add(slot[3], _mm512_extractf64x4_pd(l13, 1));
                add(slot[4], _mm512_castpd512_pd256(l46));
                add(slot[5], _mm512_castpd512_pd256(l57));
                add(slot[6], _mm512_extractf64x4_pd(l46, 1));
                add(slot[7], _mm512_extractf64x4_pd(l57, 1));
            }
#else
        for (int k = 0; k < 4; ++k)
            for (int l = 0; l < projection_lanes; ++l) {
                double* o = slot_sums + slot_stride * block.slots[k][l];
                o[0] += share[k][0][l];
                o[1] += share[k][1][l];
                o[2] += share[k][2][l];
            }
#endif
    }

} // namespace

Mat3 deformation_gradient(const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX4i>& tets, const MatX& dm_inverse, Index tet)
{
    const Vec3 x0 = positions.row(tets(tet, 0)).transpose();
    Mat3 ds;
    for (int c = 0; c < 3; ++c)
        ds.col(c) = positions.row(tets(tet, c + 1)).transpose() - x0;
    Mat3 dm_inv;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            dm_inv(r, c) = dm_inverse(tet, 3 * r + c);
    return ds * dm_inv;
}

TetProjection project_tet(const Mat3& deformation_gradient, double volume_tolerance,
    double strain_limit_min, double strain_limit_max)
{
    const Eigen::JacobiSVD<Mat3> svd(
        deformation_gradient, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Mat3 u = svd.matrixU();
    const Mat3 v = svd.matrixV();
    Vec3 s = svd.singularValues(); // decreasing, >= 0
    if (u.determinant() * v.determinant() < 0.0) {
        // Reflection: flip the smallest singular direction so that U V^T is a rotation.
        u.col(2) = -u.col(2);
        s(2) = -s(2);
    }
    TetProjection result;
    result.rotation = u * v.transpose();
    const Vec3 clamped = s.cwiseMax(strain_limit_min).cwiseMin(strain_limit_max);
    result.limit
        = clamped == s ? deformation_gradient : Mat3(u * clamped.asDiagonal() * v.transpose());

    const double det = s.prod();
    const double target = std::clamp(det, 1.0 - volume_tolerance, 1.0 + volume_tolerance);
    if (det == target) {
        result.volume = deformation_gradient;
        return result;
    }
    // min ||d - s||^2 subject to d0 d1 d2 = target. Feasible start: |s| scaled uniformly.
    Vec3 d = s.cwiseAbs();
    const double abs_prod = d.prod();
    if (abs_prod > 1e-30)
        d *= std::cbrt(target / abs_prod);
    else
        d.setConstant(std::cbrt(target));
    // Newton on the KKT conditions d - s + lambda grad C(d) = 0, C(d) = prod d - target = 0.
    Vec3 gradient(d(1) * d(2), d(0) * d(2), d(0) * d(1));
    double lambda = -gradient.dot(d - s) / std::max(gradient.squaredNorm(), 1e-300);
    for (int iteration = 0; iteration < 20; ++iteration) {
        gradient = Vec3(d(1) * d(2), d(0) * d(2), d(0) * d(1));
        const Vec3 r_d = d - s + lambda * gradient;
        const double r_c = d.prod() - target;
        if (std::max(r_d.cwiseAbs().maxCoeff(), std::abs(r_c)) < 1e-13)
            break;
        // Newton system [H g; g^T 0] [dd; dl] = -[r_d; r_c], H = I + lambda Hessian(prod d),
        // solved through the Schur complement g^T H^-1 g.
        Mat3 h = Mat3::Identity();
        h(0, 1) = h(1, 0) = lambda * d(2);
        h(0, 2) = h(2, 0) = lambda * d(1);
        h(1, 2) = h(2, 1) = lambda * d(0);
        const Mat3 h_inv = h.inverse();
        const Vec3 h_inv_g = h_inv * gradient;
        const double schur = gradient.dot(h_inv_g);
        const double d_lambda = (r_c - gradient.dot(h_inv * r_d)) / schur;
        Vec3 delta = -h_inv * r_d - h_inv_g * d_lambda;
        double step_lambda = d_lambda;
        if (!delta.allFinite() || !std::isfinite(step_lambda))
            break;
        // Halve the step until the iterate stays positive (the branch with prod d > 0).
        int halvings = 0;
        while (!((d + delta).minCoeff() > 0.0) && halvings++ < 40) {
            delta *= 0.5;
            step_lambda *= 0.5;
        }
        if (!((d + delta).minCoeff() > 0.0))
            break; // keep the last positive iterate
        d += delta;
        lambda += step_lambda;
    }
    d *= std::cbrt(target / d.prod()); // exact det (d > 0 here)
    result.volume = u * d.asDiagonal() * v.transpose();
    return result;
}

namespace {
    std::vector<int> all_tets(Index count)
    {
        std::vector<int> ids(count);
        for (Index e = 0; e < count; ++e)
            ids[e] = static_cast<int>(e);
        return ids;
    }
} // namespace

LocalStep::LocalStep(const Model& model, bool exact)
    : LocalStep(model, exact, all_tets(model.num_tets()))
{
}

LocalStep::LocalStep(const Model& model, bool exact, const std::vector<int>& ids)
    : m_num_tets(model.num_tets())
    , m_exact(exact)
{
    constexpr int lanes = projection_lanes;
    const Index t = static_cast<Index>(ids.size());
    for (const int e : ids)
        MAT_CHECK(e >= 0 && e < model.num_tets(), "local step: tet {} out of range", e);
    const Index n = model.num_nodes();
    const Index num_blocks = (t + lanes - 1) / lanes;
    const MatX4i& tets = model.tets();
    const MatX& dm_inverse = model.dm_inverse();
    const VecX& volumes = model.rest_volumes();
    m_blocks.resize(num_blocks);
    m_warm.resize(num_blocks);
    for (Index b = 0; b < num_blocks; ++b) {
        Block& block = m_blocks[b];
        const Index first = b * lanes;
        const int count = static_cast<int>(std::min<Index>(lanes, t - first)); // real tets
        for (int l = 0; l < lanes; ++l) {
            const Index e = ids[first + (l < count ? l : 0)];
            for (int c = 0; c < 4; ++c)
                block.nodes[c][l] = tets(e, c);
            for (int i = 0; i < 9; ++i)
                block.dm_inverse[i][l] = dm_inverse(e, i);
            block.volume[l] = l < count ? volumes(e) : 0.0;
        }
    }

    // Chunks: runs of consecutive blocks, a fixed number for the model (never for the thread
    // count). A chunk gives each node it touches a slot of its own, numbered in first-touch
    // order inside the chunk's slot range; a node's slots are listed in chunk order.
    const Index num_chunks = std::clamp<Index>(num_blocks / blocks_per_chunk, 1, max_chunks);
    m_chunk_blocks.assign(num_chunks + 1, 0);
    for (Index c = 0; c <= num_chunks; ++c)
        m_chunk_blocks[c] = static_cast<int>(c * num_blocks / num_chunks);
    m_chunk_slots.assign(num_chunks + 1, 0);
    std::vector<int> slot_of(n, -1); // node -> slot in the current chunk
    std::vector<int> touched;
    std::vector<std::pair<int, int>> node_slot; // (node, slot), slots ascending
    int next = 0;
    for (Index c = 0; c < num_chunks; ++c) {
        touched.clear();
        for (int b = m_chunk_blocks[c]; b < m_chunk_blocks[c + 1]; ++b) {
            Block& block = m_blocks[b];
            for (int l = 0; l < lanes; ++l)
                for (int k = 0; k < 4; ++k) {
                    const int node = block.nodes[k][l];
                    if (slot_of[node] < 0) {
                        slot_of[node] = next++;
                        touched.push_back(node);
                        node_slot.emplace_back(node, slot_of[node]);
                    }
                    block.slots[k][l] = slot_of[node];
                }
        }
        for (const int node : touched)
            slot_of[node] = -1;
        m_chunk_slots[c + 1] = next;
    }
    // Node -> slots (CSR), slots in chunk order: a stable sort by node keeps them ascending.
    std::stable_sort(node_slot.begin(), node_slot.end(),
        [](const auto& a, const auto& b) { return a.first < b.first; });
    m_node_slot_offsets.assign(n + 1, 0);
    m_node_slots.resize(node_slot.size());
    for (std::size_t i = 0; i < node_slot.size(); ++i) {
        ++m_node_slot_offsets[node_slot[i].first + 1];
        m_node_slots[i] = node_slot[i].second;
    }
    for (Index i = 0; i < n; ++i)
        m_node_slot_offsets[i + 1] += m_node_slot_offsets[i];
    for (Index i = 0; i < n; ++i)
        if (m_node_slot_offsets[i + 1] > m_node_slot_offsets[i])
            m_touched.push_back(static_cast<int>(i));
    m_slot_sums.assign(slot_stride * static_cast<std::size_t>(next), 0.0);
    m_chunk_energy.assign(static_cast<std::size_t>(num_chunks), 0.0);
}

void LocalStep::compute(
    const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs)
{
    rhs.setZero();
    run(model, positions, nullptr, rhs);
}

void LocalStep::compute_touched(
    const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs)
{
    run(model, positions, nullptr, rhs, true);
}

void LocalStep::accumulate(
    const Model& model, const Eigen::Ref<const MatX3>& positions, Eigen::Ref<MatX3> rhs)
{
    run(model, positions, nullptr, rhs);
}

void LocalStep::assemble(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3>& base, Eigen::Ref<MatX3> rhs)
{
    MAT_CHECK(base.rows() == model.num_nodes() && base.outerStride() == 3,
        "local step: base must be {} contiguous rows, has {}", model.num_nodes(), base.rows());
    run(model, positions, base.data(), rhs);
}

void LocalStep::run(const Model& model, const Eigen::Ref<const MatX3>& positions,
    const double* base, Eigen::Ref<MatX3> rhs, bool touched_only)
{
    const Index n = model.num_nodes();
    MAT_CHECK(rhs.rows() == n && rhs.outerStride() == 3,
        "local step: rhs has {} rows for a model of {} nodes (contiguous rows needed)", rhs.rows(),
        n);
    project(model, positions);
    double* out = rhs.data();
    const LocalSums node_sums = sums(nullptr);
    const int* touched = m_touched.data();
    const Index count = touched_only ? static_cast<Index>(m_touched.size()) : n;
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, count, 1024), [&](const tbb::blocked_range<Index>& range) {
            for (Index r = range.begin(); r != range.end(); ++r) {
                const Index i = touched_only ? touched[r] : r;
                double s[3];
                node_sums.slot_sum(i, s);
                const double* in = touched_only ? nullptr
                    : base != nullptr           ? base + 3 * i
                                                : out + 3 * i;
                for (int c = 0; c < 3; ++c)
                    out[3 * i + c] = in != nullptr ? in[c] + s[c] : s[c];
            }
        });
}

void LocalStep::project(const Model& model, const Eigen::Ref<const MatX3>& positions)
{
    const Index n = model.num_nodes();
    MAT_CHECK(positions.rows() == n && positions.outerStride() == 3,
        "local step: {} positions for a model of {} nodes (contiguous rows needed)",
        positions.rows(), n);
    MAT_CHECK(m_num_tets == model.num_tets(), "local step: made for {} tets, model has {}",
        m_num_tets, model.num_tets());
    ProjectionParams params;
    params.volume_tolerance = model.volume_tolerance();
    params.limit_min = model.material().strain_limit_min;
    params.limit_max = model.material().strain_limit_max;
    params.rotation_weight = model.strain_weight();
    params.volume_weight = model.volume_weight();
    params.limit_weight = model.strain_limit_weight();
    params.exact = m_exact;
    constexpr int lanes = projection_lanes;
    const double* x = positions.data(); // row-major n x 3
    double* slot_sums = m_slot_sums.data();

    // One block: gather F = Ds Dm^-1, project, scatter vol_e G_e^T target^T into rhs. With
    // G_e^T = E Dm^-1, E = [-1 -1 -1; I] (4 x 3), corner c + 1 gets row c of
    // vol_e Dm^-1 target^T and corner 0 minus their sum.
    const auto run_block = [&](int b, MatBlock& f, MatBlock& target, double& chunk_energy) {
        const Block& block = m_blocks[b];
        // Gathered corner positions, then F in SIMD over lanes.
        alignas(64) double p[4][3][lanes];
        gather_corners(block, x, p);
        for (int l = 0; l < lanes; ++l)
#pragma GCC unroll 3
            for (int r = 0; r < 3; ++r) {
                const double x0 = p[0][r][l];
                const double d0 = p[1][r][l] - x0, d1 = p[2][r][l] - x0, d2 = p[3][r][l] - x0;
#pragma GCC unroll 3
                for (int c = 0; c < 3; ++c)
                    f.m[3 * r + c][l] = d0 * block.dm_inverse[c][l]
                        + d1 * block.dm_inverse[3 + c][l] + d2 * block.dm_inverse[6 + c][l];
            }
        alignas(64) double energy[lanes];
        project_elastic_block(f, params, target, m_warm[b], m_with_energy ? energy : nullptr);
        if (m_with_energy)
            for (int l = 0; l < lanes; ++l)
                chunk_energy += block.volume[l] * energy[l];
        // Corner r + 1's share q(r, c) = vol (Dm^-1 target^T)(r, c) = vol sum_j Dm^-1(r, j)
        // target(c, j), corner 0's minus their sum, in SIMD.
        alignas(64) double share[4][3][lanes];
        for (int l = 0; l < lanes; ++l)
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c)
                    share[r + 1][c][l] = block.volume[l]
                        * (block.dm_inverse[3 * r][l] * target.m[3 * c][l]
                            + block.dm_inverse[3 * r + 1][l] * target.m[3 * c + 1][l]
                            + block.dm_inverse[3 * r + 2][l] * target.m[3 * c + 2][l]);
        for (int l = 0; l < lanes; ++l)
            for (int c = 0; c < 3; ++c)
                share[0][c][l] = -(share[1][c][l] + share[2][c][l] + share[3][c][l]);
        scatter_shares(block, share, slot_sums);
    };

    // Each chunk sums its blocks into its own slots (one thread per chunk, blocks in order),
    // then each node adds its slots in chunk order: the same sums for any thread count.
    tbb::parallel_for(
        tbb::blocked_range<int>(0, num_chunks(), 1), [&](const tbb::blocked_range<int>& range) {
            MatBlock f, target;
            for (int c = range.begin(); c != range.end(); ++c) {
                std::fill(m_slot_sums.begin() + slot_stride * m_chunk_slots[c],
                    m_slot_sums.begin() + slot_stride * m_chunk_slots[c + 1], 0.0);
                double chunk_energy = 0.0;
                for (int b = m_chunk_blocks[c]; b < m_chunk_blocks[c + 1]; ++b)
                    run_block(b, f, target, chunk_energy);
                m_chunk_energy[static_cast<std::size_t>(c)] = chunk_energy;
            }
        });
}

double LocalStep::energy() const
{
    MAT_CHECK(m_with_energy, "local step: the energy was not requested");
    double sum = 0.0; // chunk order: the same for any thread count
    for (const double e : m_chunk_energy)
        sum += e;
    return sum;
}

std::vector<float> LocalStep::warm_start() const
{
    constexpr std::size_t per_block = sizeof(RotationBlock::q) / sizeof(float);
    std::vector<float> warm(m_warm.size() * per_block);
    for (std::size_t b = 0; b < m_warm.size(); ++b)
        std::copy(&m_warm[b].q[0][0], &m_warm[b].q[0][0] + per_block, warm.data() + b * per_block);
    return warm;
}

void LocalStep::set_warm_start(const std::vector<float>& warm)
{
    constexpr std::size_t per_block = sizeof(RotationBlock::q) / sizeof(float);
    if (warm.size() != m_warm.size() * per_block)
        throw_error("local step: a warm start of {} values, expected {}", warm.size(),
            m_warm.size() * per_block);
    for (std::size_t b = 0; b < m_warm.size(); ++b)
        std::copy(
            warm.data() + b * per_block, warm.data() + (b + 1) * per_block, &m_warm[b].q[0][0]);
}

} // namespace mat
