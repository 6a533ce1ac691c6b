#pragma once
// The arithmetic of the semi-reduced step on the GPU (docs/gpu.md), as functions that compile for
// the host and for the device alike: the CUDA kernels (runtime/gpu/device_engine.cu) call them one
// tet per thread, and the CPU tests (tests/runtime/gpu/device_math_test.cpp) check them against
// the CPU path's reference projection (project_tet) on machines without a GPU.
//
// One tet's projection follows the CPU path's two decompositions (runtime/pd/elastic_term.hpp):
//   fast (the default): fast_signed_svd, float Jacobi sweeps from the warm start, V in double
//     from its quaternion, U = F V S^-1; flat or collapsed tets and a U off orthogonal fall back
//     to the exact one;
//   exact: signed_svd, Jacobi sweeps in double until the off-diagonal is below 1e-14 of the
//     trace, V's columns sorted (swaps that keep det V = +1), then a Givens QR of F V = U R:
//     U is a rotation and the signed singular values are R's diagonal (the last one negative for
//     an inverted tet), as in McAdams et al. 2011.
// Then the CPU path's projections, combined the same way:
//   target = (w_v + w_l) F + U diag(w_r + w_v (d - s) + w_l (c - s)) V^T,
// with d the volume projection's diagonal (Newton on its KKT conditions, as project_tet) and
// c = clamp(s).

#include <cmath>

#include "common/handle_monomials.hpp"
#include "common/host_device.hpp"

namespace mat::gpu {

/// The projections' settings and weights (per unit volume), as ProjectionParams.
struct ProjectionWeights {
    double volume_tolerance = 0.0;
    double limit_min = 0.0;
    double limit_max = 1e300; ///< no upper limit
    double rotation = 1.0; ///< w_r
    double volume = 0.0; ///< w_v
    double limit = 0.0; ///< w_l
    /// The exact decomposition (double Jacobi and QR), or the fast one (float eigenvectors, as
    /// the CPU path's default; see fast_signed_svd).
    bool exact = false;
};

MAT_HD double dmin(double a, double b)
{
    return a < b ? a : b;
}
MAT_HD double dmax(double a, double b)
{
    return a > b ? a : b;
}
MAT_HD double dabs(double a)
{
    return a < 0.0 ? -a : a;
}
/// 1 / sqrt(a): the GPU's reciprocal square root (one instruction sequence instead of a square
/// root and a division), the plain quotient on the host.
MAT_HD double inverse_sqrt(double a)
{
#if defined(__CUDA_ARCH__)
    return ::rsqrt(a);
#else
    return 1.0 / std::sqrt(a);
#endif
}
/// 1 / sqrt(a) in float (the GPU's approximate reciprocal square root instruction).
MAT_HD float inverse_sqrt(float a)
{
#if defined(__CUDA_ARCH__)
    return ::rsqrtf(a);
#else
    return 1.0f / std::sqrt(a);
#endif
}
/// |a| and sqrt(a) in the precision of a (the Jacobi stage runs in float and in double).
MAT_HD double magnitude(double a)
{
    return dabs(a);
}
MAT_HD float magnitude(float a)
{
    return ::fabsf(a);
}
MAT_HD double root(double a)
{
    return ::sqrt(a);
}
MAT_HD float root(float a)
{
    return ::sqrtf(a);
}
/// False for infinities and NaN (x - x is NaN for them).
MAT_HD bool finite(double a)
{
    return a - a == 0.0;
}

/// v = the rotation matrix of the quaternion (w, x, y, z) (normalized first; the identity if it
/// is zero or not finite).
MAT_HD void quaternion_to_matrix(const float (&quat)[4], double (&v)[3][3])
{
    double w = quat[0], x = quat[1], y = quat[2], z = quat[3];
    const double norm2 = w * w + x * x + y * y + z * z;
    if (!(norm2 > 1e-12) || !(norm2 < 1e30)) {
        w = 1.0;
        x = y = z = 0.0;
    } else {
        const double inv = inverse_sqrt(norm2);
        w *= inv;
        x *= inv;
        y *= inv;
        z *= inv;
    }
    v[0][0] = 1.0 - 2.0 * (y * y + z * z);
    v[0][1] = 2.0 * (x * y - w * z);
    v[0][2] = 2.0 * (x * z + w * y);
    v[1][0] = 2.0 * (x * y + w * z);
    v[1][1] = 1.0 - 2.0 * (x * x + z * z);
    v[1][2] = 2.0 * (y * z - w * x);
    v[2][0] = 2.0 * (x * z - w * y);
    v[2][1] = 2.0 * (y * z + w * x);
    v[2][2] = 1.0 - 2.0 * (x * x + y * y);
}

/// The unit quaternion of the rotation matrix v (Shepperd's method: the largest of the four
/// candidates' divisors).
MAT_HD void matrix_to_quaternion(const double (&v)[3][3], float (&quat)[4])
{
    const double trace = v[0][0] + v[1][1] + v[2][2];
    double w, x, y, z;
    if (trace >= v[0][0] && trace >= v[1][1] && trace >= v[2][2]) {
        const double r = 0.5 * inverse_sqrt(dmax(1.0 + trace, 1e-300)); // 1 / (4 w)
        w = 0.25 / r;
        x = (v[2][1] - v[1][2]) * r;
        y = (v[0][2] - v[2][0]) * r;
        z = (v[1][0] - v[0][1]) * r;
    } else if (v[0][0] >= v[1][1] && v[0][0] >= v[2][2]) {
        const double r = 0.5 * inverse_sqrt(dmax(1.0 + v[0][0] - v[1][1] - v[2][2], 1e-300));
        w = (v[2][1] - v[1][2]) * r;
        x = 0.25 / r;
        y = (v[0][1] + v[1][0]) * r;
        z = (v[0][2] + v[2][0]) * r;
    } else if (v[1][1] >= v[2][2]) {
        const double r = 0.5 * inverse_sqrt(dmax(1.0 + v[1][1] - v[0][0] - v[2][2], 1e-300));
        w = (v[0][2] - v[2][0]) * r;
        x = (v[0][1] + v[1][0]) * r;
        y = 0.25 / r;
        z = (v[1][2] + v[2][1]) * r;
    } else {
        const double r = 0.5 * inverse_sqrt(dmax(1.0 + v[2][2] - v[0][0] - v[1][1], 1e-300));
        w = (v[1][0] - v[0][1]) * r;
        x = (v[0][2] + v[2][0]) * r;
        y = (v[1][2] + v[2][1]) * r;
        z = 0.25 / r;
    }
    quat[0] = static_cast<float>(w);
    quat[1] = static_cast<float>(x);
    quat[2] = static_cast<float>(y);
    quat[3] = static_cast<float>(z);
}

/// One Jacobi rotation on the symmetric a (both triangles kept current) zeroing a[p][q],
/// accumulated into v's columns p and q, in float or double.
template <typename T> MAT_HD void jacobi_rotation(T (&a)[3][3], T (&v)[3][3], int p, int q)
{
    const T apq = a[p][q];
    if (apq == T(0))
        return;
    const T tau = (a[q][q] - a[p][p]) / (T(2) * apq);
    const T t = (tau >= T(0) ? T(1) : T(-1)) / (magnitude(tau) + root(T(1) + tau * tau));
    const T c = inverse_sqrt(T(1) + t * t);
    const T s = t * c;
    // a' = G^T a G with G = I except G_pp = G_qq = c, G_pq = s, G_qp = -s.
    const int r = 3 - p - q; // the third index
    const T app = a[p][p], aqq = a[q][q];
    a[p][p] = app - t * apq;
    a[q][q] = aqq + t * apq;
    a[p][q] = a[q][p] = T(0);
    const T arp = a[r][p], arq = a[r][q];
    a[r][p] = a[p][r] = c * arp - s * arq;
    a[r][q] = a[q][r] = s * arp + c * arq;
    for (int i = 0; i < 3; ++i) {
        const T vip = v[i][p], viq = v[i][q];
        v[i][p] = c * vip - s * viq;
        v[i][q] = s * vip + c * viq;
    }
}

/// Sorts v's columns by decreasing eigenvalue, a's diagonal; each swap negates one column, so
/// det v stays +1.
template <typename T> MAT_HD void sort_columns(const T (&a)[3][3], T (&v)[3][3])
{
    T e[3] = { a[0][0], a[1][1], a[2][2] };
    const auto swap_columns = [&](int p, int q) {
        const T t = e[p];
        e[p] = e[q];
        e[q] = t;
        for (int i = 0; i < 3; ++i) {
            const T vp = v[i][p];
            v[i][p] = -v[i][q];
            v[i][q] = vp;
        }
    };
    if (e[0] < e[1])
        swap_columns(0, 1);
    if (e[0] < e[2])
        swap_columns(0, 2);
    if (e[1] < e[2])
        swap_columns(1, 2);
}

/// Sweeps of the eigen-decomposition of a = F^T F in place from the warm start v (a is then
/// v^T F^T F v, diagonal to 1e-14 of its trace). Returns the sweeps run (at most 12).
MAT_HD int jacobi_sweeps(double (&a)[3][3], double (&v)[3][3])
{
    const double scale = dabs(a[0][0]) + dabs(a[1][1]) + dabs(a[2][2]);
    const double tolerance = 1e-14 * scale;
    int sweeps = 0;
    while (sweeps < 12) {
        const double off = dmax(dmax(dabs(a[0][1]), dabs(a[0][2])), dabs(a[1][2]));
        if (!(off > tolerance))
            break;
        jacobi_rotation(a, v, 0, 1);
        jacobi_rotation(a, v, 0, 2);
        jacobi_rotation(a, v, 1, 2);
        ++sweeps;
    }
    return sweeps;
}

/// The signed SVD F = U diag(s) V^T with U, V rotations, s sorted by decreasing magnitude and
/// only s[2] possibly negative (an inverted F). `warm`: V's quaternion, read as the Jacobi
/// stage's start and overwritten with this V.
MAT_HD void signed_svd(
    const double (&f)[3][3], float (&warm)[4], double (&u)[3][3], double (&s)[3], double (&v)[3][3])
{
    quaternion_to_matrix(warm, v);
    // a = V0^T (F^T F) V0 with B0 = F V0.
    double b[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            b[i][j] = f[i][0] * v[0][j] + f[i][1] * v[1][j] + f[i][2] * v[2][j];
    double a[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
            a[i][j] = a[j][i] = b[0][i] * b[0][j] + b[1][i] * b[1][j] + b[2][i] * b[2][j];
    jacobi_sweeps(a, v);
    sort_columns(a, v);
    matrix_to_quaternion(v, warm);
    // R = F V, then Givens QR: U^T R upper triangular, U a product of rotations.
    double r[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            r[i][j] = f[i][0] * v[0][j] + f[i][1] * v[1][j] + f[i][2] * v[2][j];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            u[i][j] = i == j ? 1.0 : 0.0;
    const int rows_p[3] = { 0, 0, 1 };
    const int rows_q[3] = { 1, 2, 2 };
    for (int g = 0; g < 3; ++g) {
        const int p = rows_p[g], q = rows_q[g], col = p; // zero r[q][col] against r[p][col]
        const double x = r[p][col], y = r[q][col];
        const double h2 = x * x + y * y;
        if (h2 == 0.0)
            continue;
        const double inv_h = inverse_sqrt(h2);
        const double c = x * inv_h, sn = y * inv_h;
        for (int j = 0; j < 3; ++j) {
            const double rp = r[p][j], rq = r[q][j];
            r[p][j] = c * rp + sn * rq;
            r[q][j] = -sn * rp + c * rq;
        }
        for (int i = 0; i < 3; ++i) {
            const double up = u[i][p], uq = u[i][q];
            u[i][p] = c * up + sn * uq;
            u[i][q] = -sn * up + c * uq;
        }
    }
    s[0] = r[0][0];
    s[1] = r[1][1];
    s[2] = r[2][2];
}

/// The fast signed SVD, the CPU path's default decomposition (runtime/pd/elastic_term.hpp): the
/// eigenvectors of F^T F by float Jacobi sweeps from the warm start (until the off-diagonal is
/// below 3e-7 of the trace, at most 4 sweeps), sorted, kept as the quaternion `warm`; V from it
/// in double (orthogonal to double precision), B = F V, s_i = |b_i|, U = B S^-1, the last
/// column and singular value negated for an inverted F. Exact at rest and under rigid motion
/// whatever V's error (F = B V^T exactly), otherwise off by about 1e-5 of the singular values'
/// spread. Returns false, for signed_svd to decompose F instead (from the updated warm start),
/// when the tet is flat or collapsed (smallest |b_i| below 5% of the largest) or U's columns are
/// farther than 2e-5 from orthogonal: the CPU path's two fallbacks.
MAT_HD bool fast_signed_svd(
    const double (&f)[3][3], float (&warm)[4], double (&u)[3][3], double (&s)[3], double (&v)[3][3])
{
    quaternion_to_matrix(warm, v);
    float vf[3][3], a[3][3];
    double b[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            vf[i][j] = static_cast<float>(v[i][j]);
            b[i][j] = f[i][0] * v[0][j] + f[i][1] * v[1][j] + f[i][2] * v[2][j];
        }
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j)
            a[i][j] = a[j][i]
                = static_cast<float>(b[0][i] * b[0][j] + b[1][i] * b[1][j] + b[2][i] * b[2][j]);
    const float tolerance = 3e-7f * (::fabsf(a[0][0]) + ::fabsf(a[1][1]) + ::fabsf(a[2][2]));
    for (int sweep = 0; sweep < 4; ++sweep) {
        if (!(::fmaxf(::fmaxf(::fabsf(a[0][1]), ::fabsf(a[0][2])), ::fabsf(a[1][2])) > tolerance))
            break;
        jacobi_rotation(a, vf, 0, 1);
        jacobi_rotation(a, vf, 0, 2);
        jacobi_rotation(a, vf, 1, 2);
    }
    sort_columns(a, vf);
    double vd[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            vd[i][j] = vf[i][j];
    matrix_to_quaternion(vd, warm);
    quaternion_to_matrix(warm, v);
    double norm[3];
    for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i)
            b[i][j] = f[i][0] * v[0][j] + f[i][1] * v[1][j] + f[i][2] * v[2][j];
        norm[j] = ::sqrt(b[0][j] * b[0][j] + b[1][j] * b[1][j] + b[2][j] * b[2][j]);
    }
    if (!(norm[2] >= 0.05 * norm[0]) || !(norm[1] >= 0.05 * norm[0]))
        return false; // flat or collapsed (or not finite)
    const double det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    for (int j = 0; j < 3; ++j) {
        s[j] = j == 2 && det < 0.0 ? -norm[j] : norm[j];
        const double inv = 1.0 / s[j];
        for (int i = 0; i < 3; ++i)
            u[i][j] = b[i][j] * inv;
    }
    const double c01 = u[0][0] * u[0][1] + u[1][0] * u[1][1] + u[2][0] * u[2][1];
    const double c02 = u[0][0] * u[0][2] + u[1][0] * u[1][2] + u[2][0] * u[2][2];
    const double c12 = u[0][1] * u[0][2] + u[1][1] * u[1][2] + u[2][1] * u[2][2];
    return dmax(dmax(dabs(c01), dabs(c02)), dabs(c12)) <= 2e-5;
}

/// The volume projection's diagonal: the point d nearest s with d0 d1 d2 = target (> 0), by
/// Newton on the KKT conditions from |s| scaled uniformly, as project_tet
/// (runtime/pd/local_step.cpp).
MAT_HD void volume_diagonal(const double (&s)[3], double target, double (&d)[3])
{
    for (int i = 0; i < 3; ++i)
        d[i] = dabs(s[i]);
    const double abs_prod = d[0] * d[1] * d[2];
    const double start = abs_prod > 1e-30 ? ::cbrt(target / abs_prod) : 0.0;
    for (int i = 0; i < 3; ++i)
        d[i] = abs_prod > 1e-30 ? d[i] * start : ::cbrt(target);
    double g[3] = { d[1] * d[2], d[0] * d[2], d[0] * d[1] };
    double lambda = -(g[0] * (d[0] - s[0]) + g[1] * (d[1] - s[1]) + g[2] * (d[2] - s[2]))
        / dmax(g[0] * g[0] + g[1] * g[1] + g[2] * g[2], 1e-300);
    for (int iteration = 0; iteration < 20; ++iteration) {
        g[0] = d[1] * d[2];
        g[1] = d[0] * d[2];
        g[2] = d[0] * d[1];
        double rd[3];
        for (int i = 0; i < 3; ++i)
            rd[i] = d[i] - s[i] + lambda * g[i];
        const double rc = d[0] * d[1] * d[2] - target;
        if (dmax(dmax(dmax(dabs(rd[0]), dabs(rd[1])), dabs(rd[2])), dabs(rc)) < 1e-13)
            break;
        // H = I + lambda Hessian(prod d), inverted by cofactors.
        const double h01 = lambda * d[2], h02 = lambda * d[1], h12 = lambda * d[0];
        const double c00 = 1.0 - h12 * h12, c01 = -(h01 - h02 * h12), c02 = h01 * h12 - h02;
        const double c11 = 1.0 - h02 * h02, c12 = -(h12 - h01 * h02), c22 = 1.0 - h01 * h01;
        const double inv_det = 1.0 / (c00 + h01 * c01 + h02 * c02);
        const double hi[3][3] = { { c00 * inv_det, c01 * inv_det, c02 * inv_det },
            { c01 * inv_det, c11 * inv_det, c12 * inv_det },
            { c02 * inv_det, c12 * inv_det, c22 * inv_det } };
        double hg[3], hr[3];
        for (int i = 0; i < 3; ++i) {
            hg[i] = hi[i][0] * g[0] + hi[i][1] * g[1] + hi[i][2] * g[2];
            hr[i] = hi[i][0] * rd[0] + hi[i][1] * rd[1] + hi[i][2] * rd[2];
        }
        const double schur = g[0] * hg[0] + g[1] * hg[1] + g[2] * hg[2];
        const double d_lambda = (rc - (g[0] * hr[0] + g[1] * hr[1] + g[2] * hr[2])) / schur;
        double delta[3];
        bool all_finite = finite(d_lambda);
        for (int i = 0; i < 3; ++i) {
            delta[i] = -hr[i] - hg[i] * d_lambda;
            all_finite = all_finite && finite(delta[i]);
        }
        if (!all_finite)
            break;
        double step_lambda = d_lambda;
        // Halve the step until the iterate stays positive (the branch with prod d > 0).
        int halvings = 0;
        while (!(dmin(dmin(d[0] + delta[0], d[1] + delta[1]), d[2] + delta[2]) > 0.0)
            && halvings++ < 40) {
            for (int i = 0; i < 3; ++i)
                delta[i] *= 0.5;
            step_lambda *= 0.5;
        }
        if (!(dmin(dmin(d[0] + delta[0], d[1] + delta[1]), d[2] + delta[2]) > 0.0))
            break;
        for (int i = 0; i < 3; ++i)
            d[i] += delta[i];
        lambda += step_lambda;
    }
    const double fix = ::cbrt(target / (d[0] * d[1] * d[2]));
    for (int i = 0; i < 3; ++i)
        d[i] *= fix;
}

/// target = w_r R(F) + w_v P_vol(F) + w_l P_lim(F), the CPU path's weighted projection
/// (runtime/pd/elastic_term.hpp), with `warm` the tet's V quaternion (read and updated).
/// Returns the constraint energy per unit volume, 1/2 sum_c w_c ||F - P_c(F)||^2.
MAT_HD double weighted_projection(
    const double (&f)[3][3], const ProjectionWeights& w, float (&warm)[4], double (&target)[3][3])
{
    double u[3][3], s[3], v[3][3];
    if (w.exact || !fast_signed_svd(f, warm, u, s, v))
        signed_svd(f, warm, u, s, v);
    double diag[3];
    double energy = 0.0;
    for (int i = 0; i < 3; ++i) {
        diag[i] = w.rotation;
        energy += 0.5 * w.rotation * (s[i] - 1.0) * (s[i] - 1.0);
    }
    const double det = s[0] * s[1] * s[2];
    const double goal = dmin(dmax(det, 1.0 - w.volume_tolerance), 1.0 + w.volume_tolerance);
    if (w.volume != 0.0 && det != goal) {
        double d[3];
        volume_diagonal(s, goal, d);
        for (int i = 0; i < 3; ++i) {
            diag[i] += w.volume * (d[i] - s[i]);
            energy += 0.5 * w.volume * (d[i] - s[i]) * (d[i] - s[i]);
        }
    }
    if (w.limit != 0.0)
        for (int i = 0; i < 3; ++i) {
            const double c = dmin(dmax(s[i], w.limit_min), w.limit_max);
            diag[i] += w.limit * (c - s[i]);
            energy += 0.5 * w.limit * (c - s[i]) * (c - s[i]);
        }
    const double keep = w.volume + w.limit; // inactive volume and limit terms give F itself
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            target[i][j] = keep * f[i][j]
                + (u[i][0] * diag[0] * v[j][0] + u[i][1] * diag[1] * v[j][1]
                    + u[i][2] * diag[2] * v[j][2]);
    return energy;
}

/// F = Ds Dm^-1 of corner positions p[4][3] and Dm^-1 (row-major, 9).
MAT_HD void deformation_gradient(
    const double (&p)[4][3], const double (&dm_inverse)[9], double (&f)[3][3])
{
    for (int r = 0; r < 3; ++r) {
        const double d0 = p[1][r] - p[0][r], d1 = p[2][r] - p[0][r], d2 = p[3][r] - p[0][r];
        for (int c = 0; c < 3; ++c)
            f[r][c] = d0 * dm_inverse[c] + d1 * dm_inverse[3 + c] + d2 * dm_inverse[6 + c];
    }
}

/// The corners' shares of vol G^T target^T (the local step's right-hand side): corner r + 1 gets
/// vol sum_j Dm^-1(r, j) target(c, j), corner 0 minus their sum (as the CPU path).
MAT_HD void corner_shares(const double (&dm_inverse)[9], double volume,
    const double (&target)[3][3], double (&share)[4][3])
{
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            share[r + 1][c] = volume
                * (dm_inverse[3 * r] * target[c][0] + dm_inverse[3 * r + 1] * target[c][1]
                    + dm_inverse[3 * r + 2] * target[c][2]);
    for (int c = 0; c < 3; ++c)
        share[0][c] = -(share[1][c] + share[2][c] + share[3][c]);
}

} // namespace mat::gpu
