#include "common/medial_primitives.hpp"

#include "common/error.hpp"
#include "common/medial_primitives_kernels.hpp"

// The primitives' value types. The math (and its derivation) is in
// medial_primitives_kernels.cpp, the whole-mesh distance in medial_primitives_field.cpp.

namespace mat {

using detail::balls_bounds;
using detail::check_sphere_index;
using detail::PairData;
using detail::SlabData;

// ---- MedialSphere ----

MedialSphere::MedialSphere(const Eigen::Ref<const Vec3>& center_, double radius_)
    : center(center_)
    , radius(radius_)
{
}

MedialSphere MedialSphere::from_mesh(const MedialMesh& mesh, Index sphere)
{
    if (sphere < 0 || sphere >= mesh.num_spheres() || mesh.radii.size() != mesh.num_spheres())
        throw_error("medial mesh: sphere {} out of range ({} spheres, {} radii)", sphere,
            mesh.num_spheres(), mesh.radii.size());
    return { mesh.centers.row(sphere).transpose(), mesh.radii(sphere) };
}

double MedialSphere::signed_distance(const Eigen::Ref<const Vec3>& p) const
{
    return (p - center).norm() - radius;
}

bool MedialSphere::contains(const Eigen::Ref<const Vec3>& p, double tolerance) const
{
    return signed_distance(p) <= tolerance;
}

Box3 MedialSphere::bounds() const
{
    return balls_bounds(&center, &radius, 1);
}

// ---- MedialCone ----

MedialCone::MedialCone(const MedialSphere& s0, const MedialSphere& s1)
    : centers { s0.center, s1.center }
    , radii { s0.radius, s1.radius }
{
}

MedialCone::MedialCone(
    const Eigen::Ref<const Vec3>& c0, double r0, const Eigen::Ref<const Vec3>& c1, double r1)
    : centers { c0, c1 }
    , radii { r0, r1 }
{
}

MedialCone MedialCone::from_mesh(const MedialMesh& mesh, Index cone)
{
    if (cone < 0 || cone >= mesh.num_cones())
        throw_error("medial mesh: cone {} out of range ({} cones)", cone, mesh.num_cones());
    for (int k = 0; k < 2; ++k)
        check_sphere_index(mesh, "cone", cone, mesh.cones(cone, k));
    return { MedialSphere::from_mesh(mesh, mesh.cones(cone, 0)),
        MedialSphere::from_mesh(mesh, mesh.cones(cone, 1)) };
}

Vec3 MedialCone::center(double t) const
{
    return (1.0 - t) * centers[0] + t * centers[1];
}

double MedialCone::radius(double t) const
{
    return (1.0 - t) * radii[0] + t * radii[1];
}

ConeDistance MedialCone::distance(const Eigen::Ref<const Vec3>& p) const
{
    return detail::cone_distance(PairData(centers[0], radii[0], centers[1], radii[1]), p);
}

double MedialCone::signed_distance(const Eigen::Ref<const Vec3>& p) const
{
    return distance(p).signed_distance;
}

bool MedialCone::contains(const Eigen::Ref<const Vec3>& p, double tolerance) const
{
    return signed_distance(p) <= tolerance;
}

Box3 MedialCone::bounds() const
{
    return balls_bounds(centers.data(), radii.data(), 2);
}

// ---- MedialSlab ----

MedialSlab::MedialSlab(const MedialSphere& s0, const MedialSphere& s1, const MedialSphere& s2)
    : centers { s0.center, s1.center, s2.center }
    , radii { s0.radius, s1.radius, s2.radius }
{
}

MedialSlab MedialSlab::from_mesh(const MedialMesh& mesh, Index slab)
{
    if (slab < 0 || slab >= mesh.num_slabs())
        throw_error("medial mesh: slab {} out of range ({} slabs)", slab, mesh.num_slabs());
    for (int k = 0; k < 3; ++k)
        check_sphere_index(mesh, "slab", slab, mesh.slabs(slab, k));
    return { MedialSphere::from_mesh(mesh, mesh.slabs(slab, 0)),
        MedialSphere::from_mesh(mesh, mesh.slabs(slab, 1)),
        MedialSphere::from_mesh(mesh, mesh.slabs(slab, 2)) };
}

Vec3 MedialSlab::center(double a, double b) const
{
    return a * centers[0] + b * centers[1] + (1.0 - a - b) * centers[2];
}

double MedialSlab::radius(double a, double b) const
{
    return a * radii[0] + b * radii[1] + (1.0 - a - b) * radii[2];
}

SlabDistance MedialSlab::distance(const Eigen::Ref<const Vec3>& p) const
{
    return SlabData(centers, radii).distance(p);
}

double MedialSlab::signed_distance(const Eigen::Ref<const Vec3>& p) const
{
    return distance(p).signed_distance;
}

bool MedialSlab::contains(const Eigen::Ref<const Vec3>& p, double tolerance) const
{
    return signed_distance(p) <= tolerance;
}

Box3 MedialSlab::bounds() const
{
    return balls_bounds(centers.data(), radii.data(), 3);
}

} // namespace mat
