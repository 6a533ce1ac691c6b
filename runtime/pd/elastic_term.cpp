#include "runtime/pd/elastic_term.hpp"

#include <algorithm>
#include <cmath>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace mat {

namespace {

    constexpr int W = projection_lanes;

    // ---- Stage 1 (float): Jacobi eigen-decomposition of A = F^T F, V as a quaternion ----

    /// sqrt(8) + 3: the approximate Givens angle is used while it stays below pi/8.
    constexpr float givens_gamma = 5.828427124746190f;
    constexpr float cos_pi_8 = 0.9238795325112867f;
    constexpr float sin_pi_8 = 0.3826834323650898f;
    /// Jacobi sweeps: at least one, more while some lane of the block has not converged (the
    /// off-diagonal of A above `tolerance` times its diagonal, in norm), up to the maximum.
    constexpr int max_float_sweeps = 4;
    constexpr float float_tolerance = 1e-5f;
    constexpr int max_double_sweeps = 2;
    constexpr double double_tolerance = 1e-13;
    /// A sweep uses small_rotation when every |a_pq| <= this times |a_pp - a_qq|.
    constexpr double small_angle_ratio = 1e-4;
    /// The fast decomposition leaves a block to the exact one when some lane's smallest
    /// singular value is below this fraction of its largest.
    constexpr double fast_min_ratio = 0.05;
    /// ... or when the columns of U = B S^-1 are farther from orthogonal than this (cosines).
    constexpr double fast_max_cosine = 2e-5;
    constexpr int volume_newton_steps = 8; ///< at most; fewer once every lane has converged
    constexpr double volume_tolerance_before_last_step = 1e-8;

    /// Lane arrays: x[l] is lane l's value.
    using FloatLanes = float[W];
    using DoubleLanes = double[W];

    /// One Jacobi rotation in the plane (p, q), k the third axis, (p, q, k) cyclic, on every
    /// lane: an approximate Givens rotation (McAdams et al. 2011, section 2.2: the half angle
    /// from tan(theta/2) ~ a_pq / (2 (a_pp - a_qq)), clamped to pi/8), applied as A <- G^T A G
    /// and v <- v * (cos(theta/2), sin(theta/2) e_k). The loop over lanes is the SIMD loop; its
    /// iterations are independent, so W / simd-width chains overlap in the pipeline.
    /// Symmetric 3x3 lanes keep their off-diagonal entries in the upper triangle only.
    constexpr int lower(int i, int j)
    {
        return i < j ? i : j;
    }
    constexpr int upper(int i, int j)
    {
        return i < j ? j : i;
    }
#define MAT_SYM(a, i, j) a[lower(i, j)][upper(i, j)]

    /// out = 1 / sqrt(x) on every lane, x >= the smallest normal float, to about 1e-7
    /// relative: with AVX-512 the 14-bit estimate and one Newton step (a fraction of the
    /// latency of a square root and a division).
    inline void inverse_sqrt(const FloatLanes& x, FloatLanes& out)
    {
#if defined(__AVX512F__)
        static_assert(W % 16 == 0, "16 floats per register");
        const __m512 half = _mm512_set1_ps(0.5f), three_halves = _mm512_set1_ps(1.5f);
        for (int l = 0; l < W; l += 16) {
            const __m512 v = _mm512_load_ps(x + l);
            const __m512 y = _mm512_maskz_rsqrt14_ps(0xFFFF, v); // masked: no spurious warning
            // y (3/2 - x y^2 / 2)
            const __m512 hxy2 = _mm512_mul_ps(_mm512_mul_ps(half, v), _mm512_mul_ps(y, y));
            _mm512_store_ps(out + l, _mm512_mul_ps(y, _mm512_sub_ps(three_halves, hxy2)));
        }
#else
        for (int l = 0; l < W; ++l)
            out[l] = 1.0f / std::sqrt(x[l]);
#endif
    }

    template <int p, int q, int k>
    inline void jacobi_rotation(float (&a)[3][3][W], FloatLanes& qw, float (&qv)[3][W])
    {
        alignas(64) float norm2[W], inverse[W];
        for (int l = 0; l < W; ++l) {
            const float ch = 2.0f * (a[p][p][l] - a[q][q][l]);
            const float sh = MAT_SYM(a, p, q)[l];
            norm2[l] = std::max(ch * ch + sh * sh, std::numeric_limits<float>::min());
        }
        inverse_sqrt(norm2, inverse);
        for (int l = 0; l < W; ++l) {
            float ch = 2.0f * (a[p][p][l] - a[q][q][l]);
            float sh = MAT_SYM(a, p, q)[l];
            const bool use = givens_gamma * sh * sh < ch * ch;
            const float inv = inverse[l];
            ch = use ? ch * inv : cos_pi_8;
            sh = use ? sh * inv : sin_pi_8;
            const float c = ch * ch - sh * sh; // cos(theta)
            const float s = 2.0f * ch * sh; // sin(theta)
            const float cc = c * c, ss = s * s, cs = c * s;
            const float app = a[p][p][l], aqq = a[q][q][l], apq = MAT_SYM(a, p, q)[l];
            const float apk = MAT_SYM(a, p, k)[l], aqk = MAT_SYM(a, q, k)[l];
            a[p][p][l] = cc * app + 2.0f * cs * apq + ss * aqq;
            a[q][q][l] = ss * app - 2.0f * cs * apq + cc * aqq;
            MAT_SYM(a, p, q)[l] = (cc - ss) * apq + cs * (aqq - app);
            MAT_SYM(a, p, k)[l] = c * apk + s * aqk;
            MAT_SYM(a, q, k)[l] = c * aqk - s * apk;
            const float w = qw[l], vp = qv[p][l], vq = qv[q][l], vk = qv[k][l];
            qw[l] = ch * w - sh * vk;
            qv[p][l] = ch * vp + sh * vq;
            qv[q][l] = ch * vq - sh * vp;
            qv[k][l] = ch * vk + sh * w;
        }
    }

    /// The double-precision working set of a block.
    struct DoubleStage {
        double v[3][3][W]; ///< V
        double b[3][3][W]; ///< F V, then R^T-rotated to upper triangular by the QR
        double a[3][3][W]; ///< (F V)^T (F V), upper triangle
        double u[3][3][W]; ///< U
    };

    /// Applies the rotation (c, s) in the plane (p, q) to lane l: A <- G^T A G, and the columns
    /// p, q of V and B.
    template <int p, int q, int k>
    inline void rotate_lane(DoubleStage& d, int l, double c, double s)
    {
        const double cc = c * c, ss = s * s, cs = c * s;
        const double app = d.a[p][p][l], aqq = d.a[q][q][l], apq = d.MAT_SYM(a, p, q)[l];
        const double apk = d.MAT_SYM(a, p, k)[l], aqk = d.MAT_SYM(a, q, k)[l];
        d.a[p][p][l] = cc * app + 2.0 * cs * apq + ss * aqq;
        d.a[q][q][l] = ss * app - 2.0 * cs * apq + cc * aqq;
        d.MAT_SYM(a, p, q)[l] = (cc - ss) * apq + cs * (aqq - app);
        d.MAT_SYM(a, p, k)[l] = c * apk + s * aqk;
        d.MAT_SYM(a, q, k)[l] = c * aqk - s * apk;
#pragma GCC unroll 3
        for (int r = 0; r < 3; ++r) {
            const double vp = d.v[r][p][l], vq = d.v[r][q][l];
            d.v[r][p][l] = c * vp + s * vq;
            d.v[r][q][l] = c * vq - s * vp;
            const double bp = d.b[r][p][l], bq = d.b[r][q][l];
            d.b[r][p][l] = c * bp + s * bq;
            d.b[r][q][l] = c * bq - s * bp;
        }
    }

    /// The same rotation angle as jacobi_rotation, in double, applied to A and to the columns
    /// p, q of V and B.
    template <int p, int q, int k> inline void polish_rotation(DoubleStage& d)
    {
        for (int l = 0; l < W; ++l) {
            double ch = 2.0 * (d.a[p][p][l] - d.a[q][q][l]);
            double sh = d.MAT_SYM(a, p, q)[l];
            const double norm2 = ch * ch + sh * sh;
            const bool use = 5.828427124746190 * sh * sh < ch * ch;
            const double inv = 1.0 / std::sqrt(std::max(norm2, std::numeric_limits<double>::min()));
            ch = use ? ch * inv : 0.9238795325112867;
            sh = use ? sh * inv : 0.3826834323650898;
            const double c = ch * ch - sh * sh;
            const double s = 2.0 * ch * sh;
            rotate_lane<p, q, k>(d, l, c, s);
        }
    }

    /// Swaps columns i and j of V and B where A's diagonal says column j is larger, negating
    /// one of them so that det V stays +1.
    inline void sort_columns(DoubleStage& d, DoubleLanes (&diag)[3], int i, int j)
    {
        for (int l = 0; l < W; ++l) {
            const bool swap = diag[i][l] < diag[j][l];
            const double di = diag[i][l], dj = diag[j][l];
            diag[i][l] = swap ? dj : di;
            diag[j][l] = swap ? di : dj;
#pragma GCC unroll 3
            for (int r = 0; r < 3; ++r) {
                const double vi = d.v[r][i][l], vj = d.v[r][j][l];
                d.v[r][i][l] = swap ? vj : vi;
                d.v[r][j][l] = swap ? -vi : vj;
                const double bi = d.b[r][i][l], bj = d.b[r][j][l];
                d.b[r][i][l] = swap ? bj : bi;
                d.b[r][j][l] = swap ? -bi : bj;
            }
        }
    }

    /// Givens rotation on rows p, q of B zeroing b[q][col] (r = sqrt(b_p^2 + b_q^2) kept in row
    /// p), accumulated into U as U <- U G^T (columns p, q). Identity when both are zero.
    template <int p, int q, int col> inline void qr_rotation(DoubleStage& d)
    {
        for (int l = 0; l < W; ++l) {
            const double x = d.b[p][col][l], y = d.b[q][col][l];
            const double r2 = x * x + y * y;
            const bool ok = r2 > std::numeric_limits<double>::min();
            const double inv = 1.0 / std::sqrt(ok ? r2 : 1.0);
            const double c = ok ? x * inv : 1.0;
            const double s = ok ? y * inv : 0.0;
#pragma GCC unroll 3
            for (int j = 0; j < 3; ++j) {
                const double bp = d.b[p][j][l], bq = d.b[q][j][l];
                d.b[p][j][l] = c * bp + s * bq;
                d.b[q][j][l] = c * bq - s * bp;
                const double up = d.u[j][p][l], uq = d.u[j][q][l];
                d.u[j][p][l] = c * up + s * uq;
                d.u[j][q][l] = c * uq - s * up;
            }
        }
    }

    /// The rotation matrix of the unit quaternion (w, x, y, z).
    template <typename T> inline void quaternion_matrix(T w, T x, T y, T z, T (&v)[3][3])
    {
        v[0][0] = T(1) - T(2) * (y * y + z * z);
        v[0][1] = T(2) * (x * y - w * z);
        v[0][2] = T(2) * (x * z + w * y);
        v[1][0] = T(2) * (x * y + w * z);
        v[1][1] = T(1) - T(2) * (x * x + z * z);
        v[1][2] = T(2) * (y * z - w * x);
        v[2][0] = T(2) * (x * z - w * y);
        v[2][1] = T(2) * (y * z + w * x);
        v[2][2] = T(1) - T(2) * (x * x + y * y);
    }

    /// True when every lane of `values` is below `limit` (a loop of its own: a max reduction
    /// inside a lane loop would keep the compiler from vectorizing that loop).
    template <typename T> inline bool all_below(const T (&values)[W], T limit)
    {
        int failing = 0; // an integer sum: vectorized, where a chain of && is one compare per lane
        for (int l = 0; l < W; ++l)
            failing += values[l] < limit ? 0 : 1; // NaN fails
        return failing == 0;
    }

    /// out = sqrt(max(x, 0)) on every lane. With AVX-512: the 14-bit reciprocal square root
    /// estimate, two Newton steps and one correction of the root (a few ulps; the hardware
    /// square root costs several times as much per lane).
    inline void sqrt_lanes(const DoubleLanes& x, DoubleLanes& out)
    {
#if defined(__AVX512F__)
        const __m512d zero = _mm512_setzero_pd(), half = _mm512_set1_pd(0.5),
                      three_halves = _mm512_set1_pd(1.5);
        for (int l = 0; l < W; l += 8) {
            const __m512d v = _mm512_max_pd(_mm512_load_pd(x + l), zero);
            __m512d y = _mm512_rsqrt14_pd(v); // +inf at 0
            const __m512d hv = _mm512_mul_pd(half, v);
            for (int step = 0; step < 2; ++step) // y (3/2 - v y^2 / 2)
                y = _mm512_mul_pd(y, _mm512_fnmadd_pd(hv, _mm512_mul_pd(y, y), three_halves));
            __m512d r = _mm512_mul_pd(v, y);
            r = _mm512_fmadd_pd(_mm512_mul_pd(half, y), _mm512_fnmadd_pd(r, r, v), r);
            const __mmask8 positive = _mm512_cmp_pd_mask(v, zero, _CMP_GT_OQ);
            _mm512_store_pd(out + l, _mm512_maskz_mov_pd(positive, r)); // 0 at 0
        }
#else
        for (int l = 0; l < W; ++l)
            out[l] = std::sqrt(std::max(x[l], 0.0));
#endif
    }

    /// out = 1 / sqrt(x) on every lane, x > 0 and normal. With AVX-512: the 14-bit estimate and
    /// two Newton steps (a few ulps), off the divider: a square root and a division per lane
    /// took the fast decomposition's largest share of cycles.
    inline void inverse_sqrt_lanes(const DoubleLanes& x, DoubleLanes& out)
    {
#if defined(__AVX512F__)
        const __m512d half = _mm512_set1_pd(0.5), three_halves = _mm512_set1_pd(1.5);
        for (int l = 0; l < W; l += 8) {
            const __m512d v = _mm512_load_pd(x + l);
            const __m512d hv = _mm512_mul_pd(half, v);
            __m512d y = _mm512_maskz_rsqrt14_pd(0xFF, v); // masked: no spurious -Wuninitialized
            for (int step = 0; step < 2; ++step) // y (3/2 - v y^2 / 2)
                y = _mm512_mul_pd(y, _mm512_fnmadd_pd(hv, _mm512_mul_pd(y, y), three_halves));
            _mm512_store_pd(out + l, y);
        }
#else
        for (int l = 0; l < W; ++l)
            out[l] = 1.0 / std::sqrt(x[l]);
#endif
    }

    /// out = a / b on every lane. With AVX-512: the 14-bit reciprocal estimate, two Newton
    /// steps and one correction of the quotient (a few ulps). A zero b gives NaN there instead
    /// of an infinity: the callers treat both as not usable.
    inline void divide_lanes(const DoubleLanes& a, const DoubleLanes& b, DoubleLanes& out)
    {
#if defined(__AVX512F__)
        const __m512d one = _mm512_set1_pd(1.0);
        for (int l = 0; l < W; l += 8) {
            const __m512d n = _mm512_load_pd(a + l), d = _mm512_load_pd(b + l);
            __m512d r = _mm512_rcp14_pd(d);
            for (int step = 0; step < 2; ++step) // r + r (1 - d r)
                r = _mm512_fmadd_pd(r, _mm512_fnmadd_pd(d, r, one), r);
            const __m512d q = _mm512_mul_pd(n, r);
            _mm512_store_pd(out + l, _mm512_fmadd_pd(r, _mm512_fnmadd_pd(d, q, n), q));
        }
#else
        for (int l = 0; l < W; ++l)
            out[l] = a[l] / b[l];
#endif
    }

    /// True when every lane's symmetric A (upper triangle) is diagonal up to `tolerance`:
    /// off-diagonal norm < tolerance * diagonal norm. One answer for the whole block.
    template <typename T> inline bool converged(const T (&a)[3][3][W], T tolerance)
    {
        alignas(64) T excess[W];
        for (int l = 0; l < W; ++l) {
            const T off
                = a[0][1][l] * a[0][1][l] + a[0][2][l] * a[0][2][l] + a[1][2][l] * a[1][2][l];
            const T diag
                = a[0][0][l] * a[0][0][l] + a[1][1][l] * a[1][1][l] + a[2][2][l] * a[2][2][l];
            excess[l] = off - tolerance * tolerance * diag;
        }
        return all_below(excess, T(0));
    }

    /// The Jacobi rotation of polish_rotation once A is nearly diagonal (every lane's
    /// |a_pq| <= small_angle_ratio |a_pp - a_qq|, see small_angles): sin = t = a_pq / (a_pp -
    /// a_qq), cos = 1 - t^2 / 2 (cos^2 + sin^2 = 1 + t^4 / 4: orthogonal to double precision),
    /// one division and no square root.
    template <int p, int q, int k> inline void small_rotation(DoubleStage& d)
    {
        for (int l = 0; l < W; ++l) {
            const double gap = d.a[p][p][l] - d.a[q][q][l];
            const double s = gap != 0.0 ? d.MAT_SYM(a, p, q)[l] / gap : 0.0;
            rotate_lane<p, q, k>(d, l, 1.0 - 0.5 * s * s, s);
        }
    }

    /// True when every lane's off-diagonal entries are below small_angle_ratio times the gap
    /// of their diagonal entries: the rotations that remain are small enough for small_rotation.
    inline bool small_angles(const DoubleStage& d)
    {
        alignas(64) double excess[W];
        for (int l = 0; l < W; ++l) {
            const double g01 = std::abs(d.a[0][0][l] - d.a[1][1][l]);
            const double g12 = std::abs(d.a[1][1][l] - d.a[2][2][l]);
            const double g02 = std::abs(d.a[0][0][l] - d.a[2][2][l]);
            const double e01 = std::abs(d.a[0][1][l]) - small_angle_ratio * g01;
            const double e12 = std::abs(d.a[1][2][l]) - small_angle_ratio * g12;
            const double e02 = std::abs(d.a[0][2][l]) - small_angle_ratio * g02;
            excess[l] = std::max(std::max(e01, e12), e02);
        }
        return all_below(excess, 1e-300);
    }

    /// Stage 1 (float): A = V0^T F^T F V0 with V0 the warm start, Jacobi sweeps until every lane
    /// is diagonal to float_tolerance; the result's quaternion goes to qw, qv and to `warm`.
    void float_stage(const MatBlock& fb, RotationBlock& warm, FloatLanes& qw, float (&qv)[3][W])
    {
        alignas(64) float a[3][3][W], norm2[W], inverse[W];
        for (int l = 0; l < W; ++l) {
            const float w = warm.q[0][l], x = warm.q[1][l], y = warm.q[2][l], z = warm.q[3][l];
            norm2[l] = std::max(w * w + x * x + y * y + z * z, std::numeric_limits<float>::min());
        }
        inverse_sqrt(norm2, inverse);
        for (int l = 0; l < W; ++l) {
            float w = warm.q[0][l], x = warm.q[1][l], y = warm.q[2][l], z = warm.q[3][l];
            const float inv = inverse[l];
            w *= inv;
            x *= inv;
            y *= inv;
            z *= inv;
            qw[l] = w;
            qv[0][l] = x;
            qv[1][l] = y;
            qv[2][l] = z;
            float v[3][3];
            quaternion_matrix(w, x, y, z, v);
            float b[3][3]; // F V0
#pragma GCC unroll 3
            for (int r = 0; r < 3; ++r)
#pragma GCC unroll 3
                for (int c = 0; c < 3; ++c)
                    b[r][c] = static_cast<float>(fb.m[3 * r][l]) * v[0][c]
                        + static_cast<float>(fb.m[3 * r + 1][l]) * v[1][c]
                        + static_cast<float>(fb.m[3 * r + 2][l]) * v[2][c];
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
                for (int j = i; j < 3; ++j)
                    a[i][j][l] = b[0][i] * b[0][j] + b[1][i] * b[1][j] + b[2][i] * b[2][j];
        }
        // No sweep when the warm start already diagonalizes A (at rest, under rigid motion, or
        // when F barely changed since the last projection).
        for (int sweep = 0; sweep < max_float_sweeps && !converged(a, float_tolerance); ++sweep) {
            jacobi_rotation<0, 1, 2>(a, qw, qv);
            jacobi_rotation<1, 2, 0>(a, qw, qv);
            jacobi_rotation<2, 0, 1>(a, qw, qv);
        }
        for (int l = 0; l < W; ++l) {
            warm.q[0][l] = qw[l];
            warm.q[1][l] = qv[0][l];
            warm.q[2][l] = qv[1][l];
            warm.q[3][l] = qv[2][l];
        }
    }

    /// Stage 2 set-up (double): V from the normalized quaternion (orthogonal to double
    /// precision) and B = F V, into d.v and d.b.
    void double_setup(
        const MatBlock& fb, const FloatLanes& qw, const float (&qv)[3][W], DoubleStage& d)
    {
        alignas(64) double norm2[W], inverse[W];
        for (int l = 0; l < W; ++l) {
            const double w = qw[l], x = qv[0][l], y = qv[1][l], z = qv[2][l];
            norm2[l] = std::max(w * w + x * x + y * y + z * z, 1e-300);
        }
        inverse_sqrt_lanes(norm2, inverse);
        for (int l = 0; l < W; ++l) {
            double w = qw[l], x = qv[0][l], y = qv[1][l], z = qv[2][l];
            const double inv = inverse[l];
            w *= inv;
            x *= inv;
            y *= inv;
            z *= inv;
            double v[3][3];
            quaternion_matrix(w, x, y, z, v);
            double b[3][3];
#pragma GCC unroll 3
            for (int r = 0; r < 3; ++r)
#pragma GCC unroll 3
                for (int c = 0; c < 3; ++c) {
                    b[r][c] = fb.m[3 * r][l] * v[0][c] + fb.m[3 * r + 1][l] * v[1][c]
                        + fb.m[3 * r + 2][l] * v[2][c];
                    d.v[r][c][l] = v[r][c];
                    d.b[r][c][l] = b[r][c];
                }
        }
    }

    /// The fast decomposition (ProjectionParams::exact false): the float stage's V made
    /// orthogonal in double, B = F V, s_i = |b_i| (the smallest negated for an inverted F; its
    /// column index goes to `smallest`, the columns are not sorted) and U = B S^-1, with no double
    /// Jacobi sweep and no QR. Then U diag(k) V^T = F V S^-1 diag(k) V^T is exact when F is a
    /// rotation times a uniform stretch (at rest, under rigid motion: |b_i| is then exact whatever
    /// V's error), and otherwise off by about the float stage's angle error times the relative
    /// spread of the singular values. Returns false, leaving the block to the exact path, when
    /// some lane's smallest singular value is below fast_min_ratio times its largest (U's error
    /// grows as their ratio) or F is not finite.
    bool fast_svd_block(const MatBlock& fb, RotationBlock& warm, DoubleStage& d,
        DoubleLanes (&s)[3], int (&smallest)[W])
    {
        alignas(64) float qw[W], qv[3][W];
        float_stage(fb, warm, qw, qv);
        double_setup(fb, qw, qv, d);
        alignas(64) double diag[3][W], excess[W], det[W];
        for (int l = 0; l < W; ++l) {
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i)
                diag[i][l] = d.b[0][i][l] * d.b[0][i][l] + d.b[1][i][l] * d.b[1][i][l]
                    + d.b[2][i][l] * d.b[2][i][l];
            const double f0 = fb.m[0][l], f1 = fb.m[1][l], f2 = fb.m[2][l], f3 = fb.m[3][l],
                         f4 = fb.m[4][l], f5 = fb.m[5][l], f6 = fb.m[6][l], f7 = fb.m[7][l],
                         f8 = fb.m[8][l];
            det[l] = f0 * (f4 * f8 - f5 * f7) - f1 * (f3 * f8 - f5 * f6) + f2 * (f3 * f7 - f4 * f6);
            const double d0 = diag[0][l], d1 = diag[1][l], d2 = diag[2][l];
            const bool first = d0 <= d1 && d0 <= d2;
            const bool second = !first && d1 <= d2;
            smallest[l] = first ? 0 : (second ? 1 : 2);
            const double least = fast_min_ratio * fast_min_ratio * std::max(std::max(d0, d1), d2);
            // Each compared on its own so that a NaN anywhere fails the test below (std::max
            // may drop one).
            excess[l] = (d0 > least) & (d1 > least) & (d2 > least) ? -1.0 : 1.0;
        }
        if (!all_below(excess, 0.0))
            return false;
        // Every diag is positive and finite here (the test above).
        alignas(64) double inverse_s[3][W];
        for (int i = 0; i < 3; ++i)
            inverse_sqrt_lanes(diag[i], inverse_s[i]);
        for (int l = 0; l < W; ++l) {
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i) {
                const bool flip = det[l] < 0.0 && smallest[l] == i;
                s[i][l] = flip ? -diag[i][l] * inverse_s[i][l] : diag[i][l] * inverse_s[i][l];
                const double inverse = flip ? -inverse_s[i][l] : inverse_s[i][l];
#pragma GCC unroll 3
                for (int r = 0; r < 3; ++r)
                    d.u[r][i][l] = d.b[r][i][l] * inverse;
            }
            // U's columns are orthogonal exactly when V is exact: their cosines measure the error.
            double worst = 0.0;
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i) {
                const int j = (i + 1) % 3;
                const double cosine = d.u[0][i][l] * d.u[0][j][l] + d.u[1][i][l] * d.u[1][j][l]
                    + d.u[2][i][l] * d.u[2][j][l];
                worst = std::max(worst, std::abs(cosine));
            }
            excess[l] = worst - fast_max_cosine;
        }
        return all_below(excess, 0.0);
    }

    /// Signed singular values and the rotations of every lane of `fb`: after the call, d.u and
    /// d.v hold U, V and s the diagonal of S (s0 >= s1 >= |s2|, s2 < 0 for an inverted F).
    void svd_block(const MatBlock& fb, RotationBlock& warm, DoubleStage& d, DoubleLanes (&s)[3])
    {
        alignas(64) float qw[W], qv[3][W];
        float_stage(fb, warm, qw, qv);
        double_setup(fb, qw, qv, d);
        for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
                for (int j = i; j < 3; ++j)
                    d.a[i][j][l] = d.b[0][i][l] * d.b[0][j][l] + d.b[1][i][l] * d.b[1][j][l]
                        + d.b[2][i][l] * d.b[2][j][l];
        for (int sweep = 0; sweep < max_double_sweeps; ++sweep) {
            if (small_angles(d)) {
                small_rotation<0, 1, 2>(d);
                small_rotation<1, 2, 0>(d);
                small_rotation<2, 0, 1>(d);
            } else {
                polish_rotation<0, 1, 2>(d);
                polish_rotation<1, 2, 0>(d);
                polish_rotation<2, 0, 1>(d);
            }
            if (sweep + 1 < max_double_sweeps && converged(d.a, double_tolerance))
                break;
        }

        alignas(64) double diag[3][W];
        for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i)
                diag[i][l] = d.a[i][i][l];
        sort_columns(d, diag, 0, 1);
        sort_columns(d, diag, 0, 2);
        sort_columns(d, diag, 1, 2);

        for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
                for (int j = 0; j < 3; ++j)
                    d.u[i][j][l] = i == j ? 1.0 : 0.0;
        qr_rotation<0, 1, 0>(d);
        qr_rotation<0, 2, 0>(d);
        qr_rotation<1, 2, 1>(d);
        for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i)
                s[i][l] = d.b[i][i][l];
    }

    /// Nearest d to the signed singular values s (|s0|, |s1| >= |s2|, only s2 may be negative) with
    /// d0 d1 d2 = t > 0, on every lane (t and cbrt(t) per lane). Stationarity of ||d - s||^2 + 2
    /// lambda (prod d - t) gives d_i (d_i - s_i) = mu, the same for all i. Parametrized by x = d2:
    /// mu = x (x - s2), d_j = (s_j + sqrt(s_j^2 + 4 mu)) / 2 for j = 0, 1 (their larger roots, real
    /// since |s_j| >= |s2|), and P(x) = x d0 d1 = t is solved by Newton steps kept inside a bracket
    /// (bisection otherwise), a fixed number of them. x >= s2 / 2 is the branch of the larger
    /// root for d2 too; when that branch cannot shrink enough (a strong one-axis stretch),
    /// x < s2 / 2 is the smaller root, still a stationary point. Finally d2 = t / (d0 d1) makes
    /// the product exact.
    void volume_block(const DoubleLanes (&s)[3], const DoubleLanes& t, const DoubleLanes& cbrt_t,
        DoubleLanes (&out)[3])
    {
        // Square roots and divisions in loops of their own, through sqrt_lanes and
        // divide_lanes (about 2 Newton steps per block on the creature).
        alignas(64) double x[W], lo[W], hi[W], r0[W], r1[W], a0[W], a1[W], num[W], den[W];
        alignas(64) double inv0[W], inv1[W], inv2[W], ones[W];
        // r_j = sqrt(s_j^2 + 4 mu), mu = x (x - s2), j = 0, 1: d_j = (s_j + r_j) / 2 at x.
        const auto roots_at = [&](const DoubleLanes& at, DoubleLanes& root0, DoubleLanes& root1) {
            for (int l = 0; l < W; ++l) {
                const double mu = at[l] * (at[l] - s[2][l]);
                a0[l] = s[0][l] * s[0][l] + 4.0 * mu;
                a1[l] = s[1][l] * s[1][l] + 4.0 * mu;
            }
            sqrt_lanes(a0, root0);
            sqrt_lanes(a1, root1);
        };
        for (int l = 0; l < W; ++l) {
            x[l] = 0.5 * std::max(s[2][l], 0.0); // h, the branches' boundary
            ones[l] = 1.0;
        }
        roots_at(x, r0, r1);
        divide_lanes(ones, s[0], inv0);
        divide_lanes(ones, s[1], inv1);
        divide_lanes(ones, s[2], inv2);
        for (int l = 0; l < W; ++l) {
            const double s0 = s[0][l], s1 = s[1][l], s2 = s[2][l];
            const bool grow = s0 * s1 * s2 < t[l];
            const double s2p = std::max(s2, 0.0);
            const double h = 0.5 * s2p;
            const double d0 = 0.5 * (s0 + r0[l]);
            const double d1 = 0.5 * (s1 + r1[l]);
            const bool upper_branch = h * d0 * d1 <= t[l];
            lo[l] = grow ? s2p : (upper_branch ? h : 0.0);
            hi[l] = grow ? s2p + cbrt_t[l] : (upper_branch ? s2p : h);
            const double start = grow ? lo[l] : hi[l];
            // From S itself (mu = 0) when s2 > 0, moved by the first-order step d_i = s_i + mu /
            // s_i, mu = (t / det - 1) / sum 1 / s_i^2 (which leaves a residual of the square of
            // the violation), if that stays in the bracket.
            const double i0 = inv0[l], i1 = inv1[l], i2 = inv2[l];
            const double mu0 = (t[l] * i0 * i1 * i2 - 1.0) / (i0 * i0 + i1 * i1 + i2 * i2);
            const double first = s2 + mu0 * i2;
            const bool inside = s2 > 0.0 && first >= lo[l] && first <= hi[l];
            x[l] = inside ? first : (s2 > 0.0 ? s2 : start);
        }
        for (int iteration = 0; iteration < volume_newton_steps; ++iteration) {
            roots_at(x, r0, r1);
            alignas(64) double residual[W]; // |P(x) - t| / t before this step
            for (int l = 0; l < W; ++l) {
                const double s0 = s[0][l], s1 = s[1][l], s2 = s[2][l], xl = x[l];
                const double d0 = 0.5 * (s0 + r0[l]), d1 = 0.5 * (s1 + r1[l]);
                const double g = xl * d0 * d1 - t[l];
                residual[l] = std::abs(g) - volume_tolerance_before_last_step * t[l];
                const double lo_l = g < 0.0 ? xl : lo[l];
                const double hi_l = g < 0.0 ? hi[l] : xl;
                lo[l] = lo_l;
                hi[l] = hi_l;
                // P'(x) = d0 d1 + x (2x - s2) (d1 / r0 + d0 / r1), multiplied through by r0 r1.
                const double e = 2.0 * xl - s2;
                num[l] = g * r0[l] * r1[l];
                den[l] = d0 * d1 * r0[l] * r1[l] + xl * e * (d1 * r1[l] + d0 * r0[l]);
            }
            divide_lanes(num, den, a0); // the Newton step
            for (int l = 0; l < W; ++l) {
                const double next = x[l] - a0[l];
                const double clamped = std::min(std::max(next, lo[l]), hi[l]);
                x[l] = clamped == next ? next : 0.5 * (lo[l] + hi[l]);
            }
            // Quadratic convergence: a residual of 1e-8 before a Newton step leaves ~1e-16.
            if (all_below(residual, 0.0))
                break;
        }
        roots_at(x, r0, r1);
        for (int l = 0; l < W; ++l) {
            out[0][l] = 0.5 * (s[0][l] + r0[l]);
            out[1][l] = 0.5 * (s[1][l] + r1[l]);
            den[l] = out[0][l] * out[1][l];
        }
        divide_lanes(t, den, out[2]);
    }

} // namespace

void project_elastic_block(const MatBlock& f, const ProjectionParams& params, MatBlock& target)
{
    RotationBlock warm;
    project_elastic_block(f, params, target, warm);
}

void project_elastic_block(const MatBlock& f, const ProjectionParams& params, MatBlock& target,
    RotationBlock& warm, double* energy)
{
    const double eps = params.volume_tolerance;
    const double t_lo = 1.0 - eps, t_hi = 1.0 + eps;
    const double wr = params.rotation_weight, wv = params.volume_weight, wl = params.limit_weight;
    const double lmin = params.limit_min, lmax = params.limit_max;

    alignas(64) DoubleStage d;
    alignas(64) double ss[3][W];
    alignas(64) int smallest[W]; // the column of the smallest |singular value|
    if (params.exact || !fast_svd_block(f, warm, d, ss, smallest)) {
        svd_block(f, warm, d, ss); // sorted: the last column is the smallest
        for (int l = 0; l < W; ++l)
            smallest[l] = 2;
    }

    // The volume projection only where some lane needs it (a branch per block, see the header).
    int num_active = 0; // an integer sum: vectorized, where a chain of |= is one compare per lane
    for (int l = 0; l < W; ++l) {
        const double det = ss[0][l] * ss[1][l] * ss[2][l];
        num_active += (det < t_lo) | (det > t_hi) ? 1 : 0;
    }
    const bool any_active = num_active > 0;
    alignas(64) double k[3][W];
    alignas(64) double e[3][W]; // w_r (s - 1)^2 + w_v (s - d)^2 + w_l (s - c)^2 per axis
    if (any_active && wv != 0.0) {
        const double cbrt_lo = std::cbrt(t_lo), cbrt_hi = std::cbrt(t_hi);
        alignas(64) double t[W], cbrt_t[W], dv[3][W];
        for (int l = 0; l < W; ++l) {
            const bool grow = ss[0][l] * ss[1][l] * ss[2][l] < t_lo;
            t[l] = grow ? t_lo : t_hi;
            cbrt_t[l] = grow ? cbrt_lo : cbrt_hi;
        }
        // volume_block wants the smallest last: swap it with column 2 there and back.
        alignas(64) double sv[3][W];
        for (int l = 0; l < W; ++l) {
            const int m = smallest[l];
            sv[0][l] = m == 0 ? ss[2][l] : ss[0][l];
            sv[1][l] = m == 1 ? ss[2][l] : ss[1][l];
            sv[2][l] = m == 0 ? ss[0][l] : (m == 1 ? ss[1][l] : ss[2][l]);
        }
        volume_block(sv, t, cbrt_t, dv);
        for (int l = 0; l < W; ++l) {
            const int m = smallest[l];
            const double d0 = dv[0][l], d1 = dv[1][l], d2 = dv[2][l];
            dv[0][l] = m == 0 ? d2 : d0;
            dv[1][l] = m == 1 ? d2 : d1;
            dv[2][l] = m == 0 ? d0 : (m == 1 ? d1 : d2);
        }
        for (int l = 0; l < W; ++l) {
            const double det = ss[0][l] * ss[1][l] * ss[2][l];
            const bool active = (det < t_lo) | (det > t_hi);
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i) {
                const double si = ss[i][l];
                const double di = active ? dv[i][l] : si;
                const double ci = std::min(std::max(si, lmin), lmax);
                k[i][l] = wr + wv * (di - si) + wl * (ci - si);
                e[i][l] = wr * (si - 1.0) * (si - 1.0) + wv * (si - di) * (si - di)
                    + wl * (si - ci) * (si - ci);
            }
        }
    } else {
        for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i) {
                const double si = ss[i][l];
                const double ci = std::min(std::max(si, lmin), lmax);
                k[i][l] = wr + wl * (ci - si);
                e[i][l] = wr * (si - 1.0) * (si - 1.0) + wl * (si - ci) * (si - ci);
            }
    }
    // The constraint distances (docs/method.md, "Accelerated iterations"): F - P = U diag(s - p)
    // V^T for each projection P = U diag(p) V^T, so ||F - P||^2 = sum_i (s_i - p_i)^2.
    if (energy != nullptr)
        for (int l = 0; l < W; ++l)
            energy[l] = 0.5 * (e[0][l] + e[1][l] + e[2][l]);

    const double wf = wv + wl;
    for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
        for (int r = 0; r < 3; ++r)
#pragma GCC unroll 3
            for (int c = 0; c < 3; ++c)
                target.m[3 * r + c][l] = wf * f.m[3 * r + c][l]
                    + d.u[r][0][l] * k[0][l] * d.v[c][0][l] + d.u[r][1][l] * k[1][l] * d.v[c][1][l]
                    + d.u[r][2][l] * k[2][l] * d.v[c][2][l];
}

} // namespace mat
