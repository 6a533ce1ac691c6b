#include "runtime/pd/projection_kernel.hpp"

#include <algorithm>
#include <cmath>

namespace mat {

namespace {

    constexpr int W = projection_lanes;

    // ---- Stage 1 (float): Jacobi eigen-decomposition of A = F^T F, V as a quaternion ----

    /// sqrt(8) + 3: the approximate Givens angle is used while it stays below pi/8.
    constexpr float givens_gamma = 5.828427124746190f;
    constexpr float cos_pi_8 = 0.9238795325112867f;
    constexpr float sin_pi_8 = 0.3826834323650898f;

    /// One Jacobi rotation in the plane (p, q), k the third axis, (p, q, k) cyclic: an
    /// approximate Givens rotation (McAdams et al. 2011, section 2.2: the half angle from
    /// tan(theta/2) ~ a_pq / (2 (a_pp - a_qq)), clamped to pi/8), applied as A <- G^T A G and
    /// v <- v * (cos(theta/2), sin(theta/2) e_k). Scalar code, the caller loops over lanes.
    template <typename T, int p, int q, int k>
    inline void jacobi_rotation(T (&a)[3][3], T& qw, T (&qv)[3], T gamma, T c_star, T s_star)
    {
        T ch = T(2) * (a[p][p] - a[q][q]);
        T sh = a[p][q];
        const T norm2 = ch * ch + sh * sh;
        const bool use = gamma * sh * sh < ch * ch;
        const T inv = T(1) / std::sqrt(std::max(norm2, std::numeric_limits<T>::min()));
        ch = use ? ch * inv : c_star;
        sh = use ? sh * inv : s_star;
        const T c = ch * ch - sh * sh; // cos(theta)
        const T s = T(2) * ch * sh; // sin(theta)
        const T cc = c * c, ss = s * s, cs = c * s;
        const T app = a[p][p], aqq = a[q][q], apq = a[p][q], apk = a[p][k], aqk = a[q][k];
        a[p][p] = cc * app + T(2) * cs * apq + ss * aqq;
        a[q][q] = ss * app - T(2) * cs * apq + cc * aqq;
        a[p][q] = a[q][p] = (cc - ss) * apq + cs * (aqq - app);
        a[p][k] = a[k][p] = c * apk + s * aqk;
        a[q][k] = a[k][q] = c * aqk - s * apk;
        const T w = qw, vp = qv[p], vq = qv[q], vk = qv[k];
        qw = ch * w - sh * vk;
        qv[p] = ch * vp + sh * vq;
        qv[q] = ch * vq - sh * vp;
        qv[k] = ch * vk + sh * w;
    }

    /// The same rotation angle, applied in double to the columns p, q of V and B and to A.
    inline void polish_rotation(
        double (&a)[3][3], double (&v)[3][3], double (&b)[3][3], int p, int q, int k)
    {
        double ch = 2.0 * (a[p][p] - a[q][q]);
        double sh = a[p][q];
        const double norm2 = ch * ch + sh * sh;
        const bool use = 5.828427124746190 * sh * sh < ch * ch;
        const double inv = 1.0 / std::sqrt(std::max(norm2, std::numeric_limits<double>::min()));
        ch = use ? ch * inv : 0.9238795325112867;
        sh = use ? sh * inv : 0.3826834323650898;
        const double c = ch * ch - sh * sh;
        const double s = 2.0 * ch * sh;
        const double cc = c * c, ss = s * s, cs = c * s;
        const double app = a[p][p], aqq = a[q][q], apq = a[p][q], apk = a[p][k], aqk = a[q][k];
        a[p][p] = cc * app + 2.0 * cs * apq + ss * aqq;
        a[q][q] = ss * app - 2.0 * cs * apq + cc * aqq;
        a[p][q] = a[q][p] = (cc - ss) * apq + cs * (aqq - app);
        a[p][k] = a[k][p] = c * apk + s * aqk;
        a[q][k] = a[k][q] = c * aqk - s * apk;
#pragma GCC unroll 16
        for (int r = 0; r < 3; ++r) {
            const double vp = v[r][p], vq = v[r][q];
            v[r][p] = c * vp + s * vq;
            v[r][q] = c * vq - s * vp;
            const double bp = b[r][p], bq = b[r][q];
            b[r][p] = c * bp + s * bq;
            b[r][q] = c * bq - s * bp;
        }
    }

    /// Swaps columns i and j of V and B if A's diagonal says column j is larger, negating one of
    /// them so that det V stays +1.
    inline void sort_columns(double (&diag)[3], double (&v)[3][3], double (&b)[3][3], int i, int j)
    {
        const bool swap = diag[i] < diag[j];
        const double di = diag[i], dj = diag[j];
        diag[i] = swap ? dj : di;
        diag[j] = swap ? di : dj;
#pragma GCC unroll 16
        for (int r = 0; r < 3; ++r) {
            const double vi = v[r][i], vj = v[r][j];
            v[r][i] = swap ? vj : vi;
            v[r][j] = swap ? -vi : vj;
            const double bi = b[r][i], bj = b[r][j];
            b[r][i] = swap ? bj : bi;
            b[r][j] = swap ? -bi : bj;
        }
    }

    /// Givens rotation on rows p, q of B zeroing b[q][col] (r = sqrt(b_p^2 + b_q^2) kept in row
    /// p), accumulated into U as U <- U G^T (columns p, q). Identity when both are zero.
    inline void qr_rotation(double (&b)[3][3], double (&u)[3][3], int p, int q, int col)
    {
        const double x = b[p][col], y = b[q][col];
        const double r2 = x * x + y * y;
        const bool ok = r2 > std::numeric_limits<double>::min();
        const double inv = 1.0 / std::sqrt(ok ? r2 : 1.0);
        const double c = ok ? x * inv : 1.0;
        const double s = ok ? y * inv : 0.0;
#pragma GCC unroll 16
        for (int j = 0; j < 3; ++j) {
            const double bp = b[p][j], bq = b[q][j];
            b[p][j] = c * bp + s * bq;
            b[q][j] = c * bq - s * bp;
            const double up = u[j][p], uq = u[j][q];
            u[j][p] = c * up + s * uq;
            u[j][q] = c * uq - s * up;
        }
    }

    /// Signed singular values and the rotations of one lane: after the call, u and v hold U, V
    /// and s the diagonal of S (s0 >= s1 >= |s2|, s2 < 0 for an inverted F).
    inline void svd_lane(
        const MatBlock& fb, int l, double (&u)[3][3], double (&s)[3], double (&v)[3][3])
    {
        double f[3][3];
#pragma GCC unroll 16
        for (int r = 0; r < 3; ++r)
#pragma GCC unroll 16
            for (int c = 0; c < 3; ++c)
                f[r][c] = fb.m[3 * r + c][l];

        // Stage 1, float.
        float a[3][3];
#pragma GCC unroll 16
        for (int i = 0; i < 3; ++i)
#pragma GCC unroll 16
            for (int j = i; j < 3; ++j) {
                const float x
                    = static_cast<float>(f[0][i] * f[0][j] + f[1][i] * f[1][j] + f[2][i] * f[2][j]);
                a[i][j] = a[j][i] = x;
            }
        float qw = 1.0f, qv[3] = { 0.0f, 0.0f, 0.0f };
#pragma GCC unroll 16
        for (int sweep = 0; sweep < 4; ++sweep) {
            jacobi_rotation<float, 0, 1, 2>(a, qw, qv, givens_gamma, cos_pi_8, sin_pi_8);
            jacobi_rotation<float, 1, 2, 0>(a, qw, qv, givens_gamma, cos_pi_8, sin_pi_8);
            jacobi_rotation<float, 2, 0, 1>(a, qw, qv, givens_gamma, cos_pi_8, sin_pi_8);
        }

        // Stage 2, double: V from the normalized quaternion, B = F V, A = B^T B.
        double w = qw, x = qv[0], y = qv[1], z = qv[2];
        const double inv = 1.0 / std::sqrt(w * w + x * x + y * y + z * z);
        w *= inv;
        x *= inv;
        y *= inv;
        z *= inv;
        v[0][0] = 1.0 - 2.0 * (y * y + z * z);
        v[0][1] = 2.0 * (x * y - w * z);
        v[0][2] = 2.0 * (x * z + w * y);
        v[1][0] = 2.0 * (x * y + w * z);
        v[1][1] = 1.0 - 2.0 * (x * x + z * z);
        v[1][2] = 2.0 * (y * z - w * x);
        v[2][0] = 2.0 * (x * z - w * y);
        v[2][1] = 2.0 * (y * z + w * x);
        v[2][2] = 1.0 - 2.0 * (x * x + y * y);
        double b[3][3];
#pragma GCC unroll 16
        for (int r = 0; r < 3; ++r)
#pragma GCC unroll 16
            for (int c = 0; c < 3; ++c)
                b[r][c] = f[r][0] * v[0][c] + f[r][1] * v[1][c] + f[r][2] * v[2][c];
        double ad[3][3];
#pragma GCC unroll 16
        for (int i = 0; i < 3; ++i)
#pragma GCC unroll 16
            for (int j = i; j < 3; ++j)
                ad[i][j] = ad[j][i] = b[0][i] * b[0][j] + b[1][i] * b[1][j] + b[2][i] * b[2][j];
#pragma GCC unroll 4
        for (int sweep = 0; sweep < 2; ++sweep) {
            polish_rotation(ad, v, b, 0, 1, 2);
            polish_rotation(ad, v, b, 1, 2, 0);
            polish_rotation(ad, v, b, 2, 0, 1);
        }

        double diag[3] = { ad[0][0], ad[1][1], ad[2][2] };
        sort_columns(diag, v, b, 0, 1);
        sort_columns(diag, v, b, 0, 2);
        sort_columns(diag, v, b, 1, 2);

#pragma GCC unroll 16
        for (int i = 0; i < 3; ++i)
#pragma GCC unroll 16
            for (int j = 0; j < 3; ++j)
                u[i][j] = i == j ? 1.0 : 0.0;
        qr_rotation(b, u, 0, 1, 0);
        qr_rotation(b, u, 0, 2, 0);
        qr_rotation(b, u, 1, 2, 1);
        s[0] = b[0][0];
        s[1] = b[1][1];
        s[2] = b[2][2];
    }

    /// Nearest d to the signed singular values s (s0 >= s1 >= |s2|) with d0 d1 d2 = t > 0.
    /// Stationarity of ||d - s||^2 + 2 lambda (prod d - t) gives d_i (d_i - s_i) = mu, the same
    /// for all i. Parametrized by x = d2: mu = x (x - s2), d_j = (s_j + sqrt(s_j^2 + 4 mu)) / 2
    /// for j = 0, 1 (their larger roots, real since |s_j| >= |s2|), and P(x) = x d0 d1 = t is
    /// solved by Newton steps kept inside a bracket (bisection otherwise), a fixed number of
    /// them. x >= s2 / 2 is the branch of the larger root for d2 too; when that branch cannot
    /// shrink enough (a strong one-axis stretch), x < s2 / 2 is the smaller root, still a
    /// stationary point. Finally d2 = t / (d0 d1) makes the product exact.
    inline void volume_lane(const double (&s)[3], double t, double cbrt_t, double (&d)[3])
    {
        const double s0 = s[0], s1 = s[1], s2 = s[2];
        const double det = s0 * s1 * s2;
        auto evaluate = [&](double x, double& d0, double& d1, double& r0, double& r1) {
            const double mu = x * (x - s2);
            r0 = std::sqrt(std::max(s0 * s0 + 4.0 * mu, 0.0));
            r1 = std::sqrt(std::max(s1 * s1 + 4.0 * mu, 0.0));
            d0 = 0.5 * (s0 + r0);
            d1 = 0.5 * (s1 + r1);
        };
        const bool grow = det < t;
        const double s2p = std::max(s2, 0.0);
        double d0, d1, r0, r1;
        evaluate(0.5 * s2p, d0, d1, r0, r1);
        const bool upper_branch = 0.5 * s2p * d0 * d1 <= t;
        double lo = grow ? s2p : (upper_branch ? 0.5 * s2p : 0.0);
        double hi = grow ? s2p + cbrt_t : (upper_branch ? s2p : 0.5 * s2p);
        double x = grow ? lo : hi;
        x = s2 > 0.0 ? s2 : x; // start at S itself when it is a point of the curve (mu = 0)
#pragma GCC unroll 16
        for (int iteration = 0; iteration < 8; ++iteration) {
            evaluate(x, d0, d1, r0, r1);
            const double g = x * d0 * d1 - t;
            lo = g < 0.0 ? x : lo;
            hi = g < 0.0 ? hi : x;
            // P'(x) = d0 d1 + x (2x - s2) (d1 / r0 + d0 / r1), multiplied through by r0 r1.
            const double e = 2.0 * x - s2;
            const double num = g * r0 * r1;
            const double den = d0 * d1 * r0 * r1 + x * e * (d1 * r1 + d0 * r0);
            const double next = x - num / den;
            x = ((next >= lo) & (next <= hi)) ? next : 0.5 * (lo + hi);
        }
        evaluate(x, d0, d1, r0, r1);
        d[0] = d0;
        d[1] = d1;
        d[2] = t / (d0 * d1);
    }

} // namespace

void project_block(const MatBlock& f, const ProjectionParams& params, MatBlock& target)
{
    const double eps = params.volume_tolerance;
    const double t_lo = 1.0 - eps, t_hi = 1.0 + eps;
    const double cbrt_lo = std::cbrt(t_lo), cbrt_hi = std::cbrt(t_hi);
    const double wr = params.rotation_weight, wv = params.volume_weight, wl = params.limit_weight;
    const double lmin = params.limit_min, lmax = params.limit_max;

    alignas(64) double us[3][3][W], vs[3][3][W], ss[3][W];
    for (int l = 0; l < W; ++l) {
        double u[3][3], s[3], v[3][3];
        svd_lane(f, l, u, s, v);
#pragma GCC unroll 16
        for (int i = 0; i < 3; ++i) {
            ss[i][l] = s[i];
#pragma GCC unroll 16
            for (int j = 0; j < 3; ++j) {
                us[i][j][l] = u[i][j];
                vs[i][j][l] = v[i][j];
            }
        }
    }

    // The volume projection only where some lane needs it (a branch per block, see the header).
    bool any_active = false;
    for (int l = 0; l < W; ++l) {
        const double det = ss[0][l] * ss[1][l] * ss[2][l];
        any_active |= (det < t_lo) | (det > t_hi);
    }
    alignas(64) double k[3][W];
    if (any_active && wv != 0.0) {
        for (int l = 0; l < W; ++l) {
            const double s[3] = { ss[0][l], ss[1][l], ss[2][l] };
            const double det = s[0] * s[1] * s[2];
            const bool grow = det < t_lo;
            const bool active = grow | (det > t_hi);
            double d[3];
            volume_lane(s, grow ? t_lo : t_hi, grow ? cbrt_lo : cbrt_hi, d);
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i) {
                const double di = active ? d[i] : s[i];
                const double ci = std::min(std::max(s[i], lmin), lmax);
                k[i][l] = wr + wv * (di - s[i]) + wl * (ci - s[i]);
            }
        }
    } else {
        for (int l = 0; l < W; ++l)
#pragma GCC unroll 3
            for (int i = 0; i < 3; ++i) {
                const double si = ss[i][l];
                const double ci = std::min(std::max(si, lmin), lmax);
                k[i][l] = wr + wl * (ci - si);
            }
    }

    const double wf = wv + wl;
    for (int l = 0; l < W; ++l)
#pragma GCC unroll 16
        for (int r = 0; r < 3; ++r)
#pragma GCC unroll 16
            for (int c = 0; c < 3; ++c)
                target.m[3 * r + c][l] = wf * f.m[3 * r + c][l]
                    + us[r][0][l] * k[0][l] * vs[c][0][l] + us[r][1][l] * k[1][l] * vs[c][1][l]
                    + us[r][2][l] * k[2][l] * vs[c][2][l];
}

} // namespace mat
