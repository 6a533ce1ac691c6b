#include "runtime/collision/primitive_pair_kernels.hpp"

#include <algorithm>
#include <cmath>

// Derivation (our own; it replaces the case analysis of Lan et al. 2020, Algorithm 1, which
// tests the corners, the four edges as 1D quadratics and the center of the conic f = 0 of the
// indefinite f = |c_a - c_b|^2 - (r_a + r_b)^2).
//
// (1) Convexity. Let a have spheres (a_i, ra_i), b have (b_j, rb_j), weights l, m in simplices.
//     g(l, m) = |C| - R with C = c_a(l) - c_b(m), R = r_a(l) + r_b(m), both affine in (l, m).
//     g is convex, and with R >= 0, f = (|C| - R)(|C| + R) has the sign of g. So min f <= 0 iff
//     min g <= 0, and the deepest penetration max(R - |C|) = -min g: one convex minimization.
//
// (2) Faces. The domain is a product of simplices; its faces are F x G for nonempty subsets F of
//     a's spheres and G of b's. A minimizer lies in the relative interior of some face, where
//     it minimizes g over the face's affine hull. On a face with base spheres i0, j0 and
//     parameters x (weights of the other spheres of F and G):
//         C(x) = C0 + J x,  R(x) = R0 + rho.x,  C0 = a_i0 - b_j0,  R0 = ra_i0 + rb_j0,
//     columns of J: a_i - a_i0 and -(b_j - b_j0); rho: ra_i - ra_i0 and rb_j - rb_j0.
//     If J has full column rank (QR: J = Q T, Q orthonormal 3 x k, T upper triangular), write
//     C = p + u with p = C0 - Q Q^T C0 (the point of the affine image closest to the origin)
//     and u in range(J); R = const + w.u with w = Q T^-T rho. Then
//         g = sqrt(|p|^2 + |u|^2) - w.u + const,
//     whose gradient vanishes at u = w |C|, i.e. |C| = |p| / sqrt(1 - |w|^2) =: s:
//         x* = z + s y,  T z = -Q^T C0,  T^T omega = rho (|w| = |omega|),  T y = omega.
//     For |w| < 1 this is the unique minimizer over the affine hull (strictly convex in u when
//     p != 0; when p = 0, |u| - w.u has its only minimum at u = 0: the centers coincide). For
//     |w| >= 1 the infimum is not attained or is attained on an unbounded ray; if J is rank
//     deficient, g is unbounded along a null direction of J or constant along a whole line.
//     In those cases the minimizers over the face, if any, reach its boundary: a smaller face
//     holds one. So the minimum of g is the least value at the corners and at the points x* of
//     the faces with full-rank J that fall inside their face. These cover Lan et al.'s cases:
//     corners; edges (k = 1: a sphere against a cone edge; rho = 0 both radii constant, etc.);
//     faces (k = 2: cone-cone interiors, sphere-slab interiors, cone edge against a sphere of a
//     slab edge) and k = 3 (a cone against a slab, or an edge against a slab, where the two
//     centers coincide). A slab-slab interior (k = 4) never has full rank and is skipped.
//     Parallel cones and collinear slab centers are rank-deficient faces, handled by their
//     boundary. Nearly parallel ones are ill-conditioned in x but not in g: J is factored by
//     Gram-Schmidt QR (not the normal equations), so C(x*) stays accurate, and x* errs along
//     the near-null direction of J, where g is flat. Every candidate is clamped into its face
//     and evaluated with g itself, so a rounding error can only raise the minimum found, never
//     lower it below the true one.
//
// (3) Duality. For any |v| <= 1, |C| >= v.C, so
//         g >= L(v) = min_i (v.a_i - ra_i) + min_j (-v.b_j - rb_j)   for all (l, m),
//     the gap between the planes of normal v that support a and b. At a minimizer the KKT
//     conditions give a v with equality: v = C / |C| when C != 0 (on a face, v = p / s + w),
//     and v = w when the centers coincide on a face with k = 3 (there J^T v = rho fixes v).
//     Restricted to a face F x G, min_{i in F} + min_{j in G} bounds g on that face.

namespace mat::detail {

namespace {

    /// How far outside its face a critical point may fall (then clamped), in weights.
    constexpr double k_face_tolerance = 1e-12;

    /// Projects weights (each >= -k_face_tolerance, summing to 1) onto the simplex.
    template <int N> void clamp_weights(double (&w)[N], int n)
    {
        bool negative = false;
        for (int i = 0; i < n; ++i)
            negative = negative || w[i] < 0.0;
        if (!negative)
            return;
        double sum = 0.0;
        for (int i = 0; i < n; ++i) {
            w[i] = std::max(w[i], 0.0);
            sum += w[i];
        }
        for (int i = 0; i < n; ++i)
            w[i] /= sum;
    }

    /// J = Q T on a face with K parameters, and rho (derivation section (2)).
    template <int K> struct FaceFactor {
        Vec3 basis[K]; ///< the columns of Q
        double t_mat[K][K] = {}; ///< T, upper triangular
        double inverse_diagonal[K]; ///< 1 / T's diagonal
        double rho[K];
    };

    /// The columns of J and rho on the face with spheres ia[0..ka) of a and ib[0..kb) of b, and
    /// J = Q T by Gram-Schmidt with reorthogonalization (twice is enough); false if J is rank
    /// deficient.
    template <int K>
    bool factor_face(const PairFrame& q, const int (&ia)[3], int ka, const int (&ib)[3], int kb,
        FaceFactor<K>& factor)
    {
        Vec3 column[K];
        int n = 0;
        for (int t = 1; t < ka; ++t, ++n) {
            column[n] = q.a[ia[t]] - q.a[ia[0]];
            factor.rho[n] = q.ra[ia[t]] - q.ra[ia[0]];
        }
        for (int t = 1; t < kb; ++t, ++n) {
            column[n] = q.b[ib[0]] - q.b[ib[t]];
            factor.rho[n] = q.rb[ib[t]] - q.rb[ib[0]];
        }
        for (int col = 0; col < K; ++col) {
            Vec3 v = column[col];
            for (int pass = 0; pass < 2; ++pass)
                for (int row = 0; row < col; ++row) {
                    const double dot = factor.basis[row].dot(v);
                    v -= dot * factor.basis[row];
                    factor.t_mat[row][col] += dot;
                }
            const double norm = v.norm();
            if (!(norm > 0.0))
                return false;
            factor.t_mat[col][col] = norm;
            factor.inverse_diagonal[col] = 1.0 / norm;
            factor.basis[col] = v * factor.inverse_diagonal[col];
        }
        return true;
    }

    /// The weights of the face's spheres at the ka + kb - 2 parameters x (clamped onto the face) in
    /// out's weights; false if x lies outside the face (NaN fails the tests too), with the sphere
    /// of the most negative weight in drop_a or drop_b.
    bool face_weights(const double* x, const int (&ia)[3], int ka, const int (&ib)[3], int kb,
        PairCandidate& out, unsigned& drop_a, unsigned& drop_b)
    {
        double wa_face[3], wb_face[3];
        double sum_a = 0.0, sum_b = 0.0;
        for (int t = 1; t < ka; ++t) {
            wa_face[t] = x[t - 1];
            sum_a += x[t - 1];
        }
        for (int t = 1; t < kb; ++t) {
            wb_face[t] = x[ka - 2 + t];
            sum_b += x[ka - 2 + t];
        }
        wa_face[0] = 1.0 - sum_a;
        wb_face[0] = 1.0 - sum_b;
        double lowest = -k_face_tolerance;
        int lowest_a = -1, lowest_b = -1;
        for (int t = 0; t < ka; ++t)
            if (!(wa_face[t] >= lowest)) {
                lowest = wa_face[t];
                lowest_a = ia[t];
            }
        for (int t = 0; t < kb; ++t)
            if (!(wb_face[t] >= lowest)) {
                lowest = wb_face[t];
                lowest_a = -1;
                lowest_b = ib[t];
            }
        if (lowest_a >= 0 || lowest_b >= 0) {
            // Outside: suggest the face without the sphere of the most negative weight.
            drop_a = lowest_a >= 0 ? 1u << lowest_a : 0u;
            drop_b = lowest_b >= 0 ? 1u << lowest_b : 0u;
            return false;
        }
        clamp_weights(wa_face, ka);
        clamp_weights(wb_face, kb);
        out.wa = { 0.0, 0.0, 0.0 };
        out.wb = { 0.0, 0.0, 0.0 };
        for (int t = 0; t < ka; ++t)
            out.wa[ia[t]] = wa_face[t];
        for (int t = 0; t < kb; ++t)
            out.wb[ib[t]] = wb_face[t];
        return true;
    }

    /// face_critical_point on the face with spheres ia[0..ka) of a and ib[0..kb) of b, with
    /// K = ka + kb - 2 parameters: x = the weights of the spheres other than ia[0] and ib[0].
    template <int K>
    bool face_critical_point(const PairFrame& q, const int (&ia)[3], int ka, const int (&ib)[3],
        int kb, PairCandidate& out, unsigned& drop_a, unsigned& drop_b)
    {
        FaceFactor<K> factor;
        if (!factor_face(q, ia, ka, ib, kb, factor))
            return false; // rank deficient: a smaller face holds the minimizer

        // T^T omega = rho (forward substitution); |w| = |omega|.
        double omega[K];
        double w2 = 0.0;
        for (int row = 0; row < K; ++row) {
            double sum = factor.rho[row];
            for (int col = 0; col < row; ++col)
                sum -= factor.t_mat[col][row] * omega[col];
            omega[row] = sum * factor.inverse_diagonal[row];
            w2 += omega[row] * omega[row];
        }
        if (!(w2 < 1.0))
            return false; // no minimizer inside the affine hull

        // p = C0 - Q Q^T C0 (twice, for accuracy when C0 is nearly in range(J)).
        double qc[K] = {};
        Vec3 p = q.a[ia[0]] - q.b[ib[0]];
        for (int pass = 0; pass < 2; ++pass)
            for (int row = 0; row < K; ++row) {
                const double dot = factor.basis[row].dot(p);
                p -= dot * factor.basis[row];
                qc[row] += dot;
            }
        if (K == 3)
            p = Vec3::Zero(); // range(J) = R^3: the residual is rounding, and its direction
                              // would spoil the dual vector below

        // x* = z + s y with T z = -Q^T C0, T y = omega (back substitution).
        const double s = p.norm() / std::sqrt(1.0 - w2);
        double x[K];
        for (int row = K - 1; row >= 0; --row) {
            double sum = -qc[row] + s * omega[row];
            for (int col = row + 1; col < K; ++col)
                sum -= factor.t_mat[row][col] * x[col];
            x[row] = sum * factor.inverse_diagonal[row];
        }

        // Weights; reject points outside the face.
        if (!face_weights(x, ia, ka, ib, kb, out, drop_a, drop_b))
            return false;

        // Dual vector of section (3): v = p / s + w (w when the centers coincide).
        Vec3 w = Vec3::Zero();
        for (int row = 0; row < K; ++row)
            w += omega[row] * factor.basis[row];
        out.dual = s > 0.0 ? Vec3(p / s + w) : w;
        const double dual_norm = out.dual.norm();
        if (dual_norm > 1.0)
            out.dual /= dual_norm; // rounding: L(v) bounds g only for |v| <= 1
        return true;
    }

} // namespace

PairCandidate corner_candidate(const PairFrame& q, int i, int j)
{
    PairCandidate x;
    x.wa[i] = 1.0;
    x.wb[j] = 1.0;
    x.c = q.a[i] - q.b[j];
    const double norm = x.c.norm();
    x.g = norm - (q.ra[i] + q.rb[j]);
    x.dual = norm > 0.0 ? Vec3(x.c / norm) : Vec3(Vec3::Zero());
    x.mask_a = 1u << i;
    x.mask_b = 1u << j;
    return x;
}

void evaluate_candidate(const PairFrame& q, PairCandidate& x)
{
    Vec3 c = Vec3::Zero();
    double r = 0.0;
    for (int i = 0; i < q.na; ++i) {
        c += x.wa[i] * q.a[i];
        r += x.wa[i] * q.ra[i];
    }
    for (int j = 0; j < q.nb; ++j) {
        c -= x.wb[j] * q.b[j];
        r += x.wb[j] * q.rb[j];
    }
    x.c = c;
    x.g = c.norm() - r;
}

bool face_critical_point(const PairFrame& q, unsigned mask_a, unsigned mask_b, int k,
    PairCandidate& out, unsigned& drop_a, unsigned& drop_b)
{
    drop_a = drop_b = 0u;
    int ia[3] = { 0, 0, 0 }, ib[3] = { 0, 0, 0 }, ka = 0, kb = 0;
    for (int i = 0; i < q.na; ++i)
        if (mask_a >> i & 1u)
            ia[ka++] = i;
    for (int j = 0; j < q.nb; ++j)
        if (mask_b >> j & 1u)
            ib[kb++] = j;
    if (ka == 0 || kb == 0 || ka + kb - 2 != k)
        return false;
    if (k == 1)
        return face_critical_point<1>(q, ia, ka, ib, kb, out, drop_a, drop_b);
    if (k == 2)
        return face_critical_point<2>(q, ia, ka, ib, kb, out, drop_a, drop_b);
    if (k == 3)
        return face_critical_point<3>(q, ia, ka, ib, kb, out, drop_a, drop_b);
    return false;
}

} // namespace mat::detail
