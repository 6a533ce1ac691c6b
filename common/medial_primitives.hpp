#pragma once
// Medial primitives (docs/method.md, section 1): a sphere; a cone, the linear interpolation of 2
// spheres; a slab, the barycentric interpolation of 3 spheres. The volume of a primitive is the
// union of its interpolated spheres, which equals the convex hull of its 2 or 3 spheres. The
// envelope of a medial mesh is the union of all its primitives and of the spheres no primitive
// uses.
//
// Signed distances are negative inside and positive outside and exact on both sides up to
// rounding (derivation at the top of medial_primitives_kernels.cpp): outside, the distance to
// the union of interpolated spheres; inside, the distance to the boundary of their convex hull,
// which is not min_t |p - c(t)| - r(t). Every function here is safe to call concurrently.

#include <array>
#include <memory>

#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// Distance from a point to a cone, with the parameter of the sphere that realizes it.
struct ConeDistance {
    /// Exact signed distance to the cone's volume (negative inside).
    double signed_distance = 0.0;
    /// min over t of |p - c(t)| - r(t). Equals signed_distance outside; inside it is >=
    /// signed_distance (it is minus the depth of p in its deepest interpolated sphere).
    double sphere_distance = 0.0;
    /// The minimizer t in [0, 1] of sphere_distance: outside, S(t) touches the closest point of
    /// the volume; inside, S(t) is the interpolated sphere that contains p most deeply.
    double t = 0.0;
};

/// Distance from a point to a slab, with the parameter of the sphere that realizes it.
struct SlabDistance {
    /// Exact signed distance to the slab's volume (negative inside).
    double signed_distance = 0.0;
    /// min over (a, b) of |p - c(a, b)| - r(a, b); equals signed_distance outside, >= inside.
    double sphere_distance = 0.0;
    /// The minimizer (a, b) of sphere_distance: weights of spheres 0 and 1 (sphere 2 gets
    /// 1 - a - b), a, b >= 0, a + b <= 1.
    Vec2 ab = Vec2::Zero();
};

/// A sphere (center, radius >= 0).
struct MedialSphere {
    Vec3 center = Vec3::Zero();
    double radius = 0.0;

    MedialSphere() = default;
    MedialSphere(const Eigen::Ref<const Vec3>& center, double radius);
    /// Sphere `sphere` of `mesh`; throws mat::Error if the index is out of range.
    static MedialSphere from_mesh(const MedialMesh& mesh, Index sphere);

    /// |p - c| - r.
    double signed_distance(const Eigen::Ref<const Vec3>& p) const;
    /// signed_distance(p) <= tolerance.
    bool contains(const Eigen::Ref<const Vec3>& p, double tolerance = 0.0) const;
    /// Axis-aligned bounding box of the ball.
    Box3 bounds() const;
};

/// A medial cone: c(t) = (1-t) c0 + t c1, r(t) = (1-t) r0 + t r1, t in [0, 1].
struct MedialCone {
    std::array<Vec3, 2> centers = { Vec3::Zero(), Vec3::Zero() };
    std::array<double, 2> radii = { 0.0, 0.0 };

    MedialCone() = default;
    MedialCone(const MedialSphere& s0, const MedialSphere& s1);
    MedialCone(
        const Eigen::Ref<const Vec3>& c0, double r0, const Eigen::Ref<const Vec3>& c1, double r1);
    /// Cone `cone` of `mesh`; throws mat::Error on an out-of-range cone or sphere index.
    static MedialCone from_mesh(const MedialMesh& mesh, Index cone);

    Vec3 center(double t) const;
    double radius(double t) const;
    MedialSphere sphere(double t) const { return { center(t), radius(t) }; }

    /// Exact signed distance, with the parameter of the minimizing sphere.
    ConeDistance distance(const Eigen::Ref<const Vec3>& p) const;
    double signed_distance(const Eigen::Ref<const Vec3>& p) const;
    /// signed_distance(p) <= tolerance (consistent with the sign of signed_distance).
    bool contains(const Eigen::Ref<const Vec3>& p, double tolerance = 0.0) const;
    /// Axis-aligned bounding box of the volume.
    Box3 bounds() const;
};

/// A medial slab: c(a, b) = a c0 + b c1 + (1-a-b) c2, same for r, a, b >= 0, a + b <= 1.
struct MedialSlab {
    std::array<Vec3, 3> centers = { Vec3::Zero(), Vec3::Zero(), Vec3::Zero() };
    std::array<double, 3> radii = { 0.0, 0.0, 0.0 };

    MedialSlab() = default;
    MedialSlab(const MedialSphere& s0, const MedialSphere& s1, const MedialSphere& s2);
    /// Slab `slab` of `mesh`; throws mat::Error on an out-of-range slab or sphere index.
    static MedialSlab from_mesh(const MedialMesh& mesh, Index slab);

    Vec3 center(double a, double b) const;
    double radius(double a, double b) const;
    MedialSphere sphere(double a, double b) const { return { center(a, b), radius(a, b) }; }

    /// Exact signed distance, with the parameter of the minimizing sphere.
    SlabDistance distance(const Eigen::Ref<const Vec3>& p) const;
    double signed_distance(const Eigen::Ref<const Vec3>& p) const;
    /// signed_distance(p) <= tolerance (consistent with the sign of signed_distance).
    bool contains(const Eigen::Ref<const Vec3>& p, double tolerance = 0.0) const;
    /// Axis-aligned bounding box of the volume.
    Box3 bounds() const;
};

/// Signed distance from p to the envelope of `mesh` (union of its cones, slabs and spheres):
/// the minimum over primitives of their exact signed distances. Guarantees:
///  - the sign is right: value <= 0 iff some primitive contains p (its contains(p));
///  - outside, the value is the exact distance to the envelope;
///  - inside, the value is -(max over primitives of the depth of p in that primitive). The
///    ball of that radius around p lies inside the envelope, so |value| <= the true depth; it is
///    exact whenever the closest boundary point of the deepest primitive lies on no other
///    primitive (in particular where only one primitive is near p).
/// The value is 1-Lipschitz in p. Returns +infinity for a mesh without spheres. Throws
/// mat::Error on an out-of-range index. Fast for repeated calls: each thread keeps a
/// MedialDistanceField of the last mesh it saw (and a copy of that mesh), rebuilt when the mesh
/// differs bitwise; the per-call check costs a memcmp of the mesh arrays. Holding a
/// MedialDistanceField yourself spares that check.
double medial_mesh_signed_distance(const MedialMesh& mesh, const Eigen::Ref<const Vec3>& p);

/// medial_mesh_signed_distance with per-primitive data precomputed once (tangent cones and
/// planes) and a bounding-box hierarchy of the primitives (a subtree is skipped only when its
/// box proves it cannot lower the minimum, so the value is the same). Immutable after
/// construction; copies share the data; concurrent calls are safe.
class MedialDistanceField {
public:
    /// Validates the indices of `mesh` (throws mat::Error naming the bad element) and
    /// precomputes. Keeps no reference to `mesh`.
    explicit MedialDistanceField(const MedialMesh& mesh);

    /// Same value as medial_mesh_signed_distance(mesh, p).
    double operator()(const Vec3& p) const;
    double signed_distance(const Eigen::Ref<const Vec3>& p) const;

    /// Bounding box of the envelope (empty box for a mesh without spheres).
    Box3 bounds() const;

private:
    struct Data;
    std::shared_ptr<const Data> m_data;
};

} // namespace mat
