#pragma once
// Exact narrow-phase tests between two medial primitives (docs/method.md, section 4, step 4; Lan
// et al. 2020, "Medial Elastics", section 5: the primitive-primitive test as a quadratically
// constrained quadratic program).
//
// A primitive is 1 (sphere), 2 (cone) or 3 (slab) spheres; its volume is the union of the spheres
// c(w) = sum_i w_i c_i, r(w) = sum_i w_i r_i over barycentric weights w (which is the convex hull
// of its balls). For two primitives a, b with weights l, m let
//     g(l, m) = |c_a(l) - c_b(m)| - (r_a(l) + r_b(m)).
// The volumes intersect iff min g <= 0 (equivalently min f <= 0 for Lan et al.'s indefinite
// f = |c_a - c_b|^2 - (r_a + r_b)^2, since radii are >= 0). The deepest penetration is
// max (-g) = -min g: the depth of the most overlapping pair of interpolated spheres when the
// volumes intersect, minus the distance between the two volumes when they do not. g is convex
// (a norm of an affine map minus an affine map), so both answers come from one exact
// minimization; the derivation is at the top of primitive_pair.cpp.
//
// Free functions, no allocation, safe to call concurrently.

#include <array>

#include "common/eigen_types.hpp"

namespace mat {

/// A medial primitive at runtime (deformed centers, enlarged radii): a flat copyable value.
struct Primitive {
    /// 1 sphere, 2 a cone, 3 a slab. Only the first `count` centers and radii are used.
    int count = 1;
    std::array<Vec3, 3> centers = { Vec3::Zero(), Vec3::Zero(), Vec3::Zero() };
    /// Radii >= 0.
    std::array<double, 3> radii = { 0.0, 0.0, 0.0 };

    static Primitive sphere(const Vec3& c0, double r0);
    static Primitive cone(const Vec3& c0, double r0, const Vec3& c1, double r1);
    static Primitive slab(
        const Vec3& c0, double r0, const Vec3& c1, double r1, const Vec3& c2, double r2);

    /// sum_i weights_i centers_i over the first `count` spheres.
    Vec3 center(const Vec3& weights) const;
    /// sum_i weights_i radii_i over the first `count` spheres.
    double radius(const Vec3& weights) const;
};

/// The pair of interpolated spheres of two primitives with the largest penetration depth.
struct PrimitivePenetration {
    /// max over weights of r_a + r_b - |c_a - c_b|: > 0 when the volumes overlap, else minus the
    /// distance between the two volumes.
    double depth = 0.0;
    /// Barycentric weights of the spheres of a and of b (>= 0, summing to 1; entries past the
    /// primitive's count are 0).
    Vec3 weights_a = Vec3::Zero();
    Vec3 weights_b = Vec3::Zero();
    /// The two interpolated spheres at these weights.
    Vec3 center_a = Vec3::Zero();
    Vec3 center_b = Vec3::Zero();
    double radius_a = 0.0;
    double radius_b = 0.0;
    /// Unit vector from center_b to center_a. When the centers coincide: the direction from the
    /// centroid of b's centers to the centroid of a's, or +z if these coincide too.
    Vec3 normal = Vec3::UnitZ();
};

/// Whether the volumes of a and b intersect (touching counts): min g <= tolerance, with a
/// tolerance of 1e-14 x the extent of the pair's balls that absorbs rounding, so that pairs
/// touching up to rounding are reported (a false positive only costs a triangle-level test).
/// Consistent with deepest_penetration: when this returns true, its depth is >= -1e-13 x the
/// size of the pair. Throws mat::Error on a count outside 1..3, a negative or non-finite radius
/// or a non-finite center.
bool primitives_intersect(const Primitive& a, const Primitive& b);

/// The exact maximum over both primitives' weights of r_a + r_b - |c_a - c_b|, with the spheres
/// that realize it. Swapping a and b gives the same depth, swapped weights and spheres and the
/// opposite normal (but the same fallback +z). Throws like primitives_intersect.
PrimitivePenetration deepest_penetration(const Primitive& a, const Primitive& b);

} // namespace mat
