#pragma once
// Internal kernels of the primitive-pair tests (runtime/collision/primitive_pair.hpp): the pair in
// local coordinates, points of the parameter domain, the dual bound and the closed-form critical
// point of g on a face of the domain. The derivation is at the top of primitive_pair_kernels.cpp.

#include <algorithm>
#include <array>
#include <limits>

#include "common/eigen_types.hpp"

namespace mat::detail {

/// Two primitives in local coordinates (origin at the first center of a): a has spheres
/// (a_i, ra_i), i < na; b has (b_j, rb_j), j < nb.
struct PairFrame {
    int na = 1, nb = 1;
    std::array<Vec3, 3> a, b;
    std::array<double, 3> ra {}, rb {};
};

/// A point of the parameter domain: barycentric weights of a's and b's spheres, with
/// C = c_a - c_b, g = |C| - R, a dual vector v (|v| <= 1) and the face it was found on.
struct PairCandidate {
    std::array<double, 3> wa {}, wb {};
    Vec3 c = Vec3::Zero();
    double g = std::numeric_limits<double>::infinity();
    Vec3 dual = Vec3::Zero();
    unsigned mask_a = 0, mask_b = 0; ///< the face: bit i set for each sphere it spans
};

/// The corner (sphere i of a, sphere j of b), with the dual vector C / |C| (0 if C = 0).
PairCandidate corner_candidate(const PairFrame& q, int i, int j);

/// Sets x.c and x.g from x's weights.
void evaluate_candidate(const PairFrame& q, PairCandidate& x);

/// The critical point of g on the affine hull of the face (mask_a x mask_b), with k = 1..3
/// parameters (popcount(mask_a) + popcount(mask_b) - 2), if it exists and lies in the face
/// (derivation section (2)); sets out's weights and dual vector (not c, g or the masks). When the
/// point exists but lies outside the face, drop_a or drop_b is set to the bit of the sphere with
/// the most negative weight there; otherwise both are 0.
bool face_critical_point(const PairFrame& q, unsigned mask_a, unsigned mask_b, int k,
    PairCandidate& out, unsigned& drop_a, unsigned& drop_b);

inline int popcount3(unsigned mask)
{
    return (mask & 1u) + (mask >> 1 & 1u) + (mask >> 2 & 1u);
}

/// The bound L(v) of derivation section (3), split by sphere: la_i = v.a_i - ra_i,
/// lb_j = -v.b_j - rb_j. For |v| <= 1, g >= min_{i in F} la_i + min_{j in G} lb_j on the face
/// F x G.
struct DualBound {
    std::array<double, 3> la { std::numeric_limits<double>::infinity(),
        std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity() };
    std::array<double, 3> lb = la;

    DualBound() = default;
    DualBound(const PairFrame& q, const Vec3& v)
    {
        for (int i = 0; i < q.na; ++i)
            la[i] = v.dot(q.a[i]) - q.ra[i];
        for (int j = 0; j < q.nb; ++j)
            lb[j] = -v.dot(q.b[j]) - q.rb[j];
    }
    /// The bound on the face (mask_a x mask_b).
    double face(unsigned mask_a, unsigned mask_b) const
    {
        double min_a = std::numeric_limits<double>::infinity(), min_b = min_a;
        for (int i = 0; i < 3; ++i) {
            if (mask_a >> i & 1u)
                min_a = std::min(min_a, la[i]);
            if (mask_b >> i & 1u)
                min_b = std::min(min_b, lb[i]);
        }
        return min_a + min_b;
    }
};

} // namespace mat::detail
