#include "preprocess/medial/local_envelope.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mat {

LocalEnvelope::LocalEnvelope(const Vec4& sphere)
    : m_center(sphere.head<3>())
    , m_radius(sphere(3))
{
    m_spheres.push_back(sphere);
}

void LocalEnvelope::add_sphere(const Vec4& sphere)
{
    m_spheres.push_back(sphere);
}

void LocalEnvelope::reserve(std::size_t spheres, std::size_t primitives)
{
    m_spheres.reserve(spheres + 1);
    m_primitives.reserve(primitives);
}

void LocalEnvelope::add_cone(const Vec4& other)
{
    add(2, other, other);
}

void LocalEnvelope::add_slab(const Vec4& first, const Vec4& second)
{
    add(3, first, second);
}

void LocalEnvelope::add(int count, const Vec4& first, const Vec4& second)
{
    Primitive primitive;
    primitive.count = count;
    primitive.centers = { m_center, first.head<3>(), second.head<3>() };
    primitive.radii = { m_radius, first(3), second(3) };
    for (int i = 0; i < count; ++i)
        primitive.centroid += primitive.centers[static_cast<std::size_t>(i)] / count;
    for (int i = 0; i < count; ++i)
        primitive.reach = std::max(primitive.reach,
            (primitive.centers[static_cast<std::size_t>(i)] - primitive.centroid).norm()
                + primitive.radii[static_cast<std::size_t>(i)]);
    m_primitives.push_back(primitive);
}

// The larger of two lower bounds of the signed distance to the convex hull of the balls: to
// the ball (centroid, reach) that holds it, and to its supporting plane of normal n = (p -
// centroid) / |p - centroid|, n.p - max_i (n.c_i + r_i) (exact when p faces a flat side).
double LocalEnvelope::lower_bound(const Primitive& primitive, const Vec3& p)
{
    const Vec3 offset = p - primitive.centroid;
    const double length = offset.norm();
    if (!(length > 0))
        return -std::numeric_limits<double>::infinity();
    const Vec3 n = offset / length;
    double support = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < primitive.count; ++i)
        support = std::max(support,
            n.dot(primitive.centers[static_cast<std::size_t>(i)])
                + primitive.radii[static_cast<std::size_t>(i)]);
    return std::max(length - primitive.reach, n.dot(p) - support);
}

double LocalEnvelope::signed_distance(const Vec3& p)
{
    // Every primitive holds its corner spheres, so the nearest sphere bounds the value from
    // above; a primitive whose lower bound exceeds max(d, 0) can neither be closer (outside)
    // nor hold p more deeply (inside).
    double d = std::numeric_limits<double>::infinity();
    for (const Vec4& sphere : m_spheres)
        d = std::min(d, (p - sphere.head<3>()).norm() - sphere(3));
    for (Primitive& primitive : m_primitives) {
        const double limit = std::max(d, 0.0);
        if ((p - primitive.centroid).norm() - primitive.reach > limit
            || lower_bound(primitive, p) > limit)
            continue;
        if (primitive.count == 2) {
            if (!primitive.ready)
                primitive.cone = detail::PairData(primitive.centers[0], primitive.radii[0],
                    primitive.centers[1], primitive.radii[1]);
            primitive.ready = true;
            d = std::min(d, detail::cone_distance(primitive.cone, p).signed_distance);
        } else {
            if (!primitive.ready)
                primitive.slab = detail::SlabData(primitive.centers, primitive.radii);
            primitive.ready = true;
            d = std::min(d, primitive.slab.distance(p).signed_distance);
        }
    }
    return d;
}

double LocalEnvelope::max_squared_distance(const Eigen::Ref<const MatX3>& points,
    const std::vector<int>& ids, double bound, std::size_t budget)
{
    const std::size_t n = ids.size();
    const std::size_t head = budget == 0 ? n : std::min(n, budget);
    const std::size_t stride = head == n ? 1 : (n - head + budget - 1) / budget;
    double worst = 0.0;
    for (std::size_t i = 0; i < n; i += i < head ? 1 : stride) {
        const double d = signed_distance(points.row(ids[i]).transpose());
        worst = std::max(worst, d * d);
        if (worst > bound)
            break;
    }
    return worst;
}

void LocalEnvelope::squared_distances(
    const Eigen::Ref<const MatX3>& points, const std::vector<int>& ids, std::vector<double>& out)
{
    out.resize(ids.size());
    for (std::size_t i = 0; i < ids.size(); ++i) {
        const double d = signed_distance(points.row(ids[i]).transpose());
        out[i] = d * d;
    }
}

} // namespace mat
