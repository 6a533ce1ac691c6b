#include "preprocess/medial/surface_distance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "common/error.hpp"

namespace mat {
namespace {

    constexpr int k_leaf_size = 4;

    double box_squared_distance(const Box3& box, const Vec3& p)
    {
        const Vec3 below = (box.min() - p).cwiseMax(0.0);
        const Vec3 above = (p - box.max()).cwiseMax(0.0);
        return (below + above).squaredNorm();
    }

    std::uint64_t edge_key(int a, int b)
    {
        if (a > b)
            std::swap(a, b);
        return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32)
            | static_cast<std::uint32_t>(b);
    }

} // namespace

SurfaceDistance::SurfaceDistance(const SurfaceMesh& surface)
    : m_positions(surface.positions)
    , m_faces(surface.faces)
{
    const Index num_faces = m_faces.rows();
    if (num_faces == 0)
        throw_error("surface distance: the surface has no face");
    const Index num_vertices = m_positions.rows();
    for (Index v = 0; v < num_vertices; ++v)
        m_bounds.extend(m_positions.row(v).transpose());

    // Face normals, and angle-weighted vertex pseudo-normals.
    m_face_normals.setZero(num_faces, 3);
    m_vertex_normals.setZero(num_vertices, 3);
    for (Index f = 0; f < num_faces; ++f) {
        const Vec3 x[3] = { m_positions.row(m_faces(f, 0)), m_positions.row(m_faces(f, 1)),
            m_positions.row(m_faces(f, 2)) };
        const Vec3 normal = (x[1] - x[0]).cross(x[2] - x[0]).normalized();
        if (!normal.allFinite())
            continue; // a degenerate face contributes nothing to any sign
        m_face_normals.row(f) = normal.transpose();
        for (int k = 0; k < 3; ++k) {
            const Vec3 u = (x[(k + 1) % 3] - x[k]).normalized();
            const Vec3 w = (x[(k + 2) % 3] - x[k]).normalized();
            const double angle = std::acos(std::clamp(u.dot(w), -1.0, 1.0));
            m_vertex_normals.row(m_faces(f, k)) += angle * normal.transpose();
        }
    }

    // Edge pseudo-normals: the sum of the normals of the faces that share the edge.
    std::unordered_map<std::uint64_t, Vec3> edge_sums;
    edge_sums.reserve(static_cast<std::size_t>(3 * num_faces));
    for (Index f = 0; f < num_faces; ++f)
        for (int k = 0; k < 3; ++k) {
            auto [it, inserted] = edge_sums.try_emplace(
                edge_key(m_faces(f, k), m_faces(f, (k + 1) % 3)), Vec3::Zero());
            it->second += m_face_normals.row(f).transpose();
        }
    m_edge_normals.resize(3 * num_faces, 3);
    for (Index f = 0; f < num_faces; ++f)
        for (int k = 0; k < 3; ++k)
            m_edge_normals.row(3 * f + k)
                = edge_sums.at(edge_key(m_faces(f, k), m_faces(f, (k + 1) % 3))).transpose();

    // The hierarchy: median splits along the longest axis of the centroids' box.
    std::vector<Vec3> centroids(static_cast<std::size_t>(num_faces));
    for (Index f = 0; f < num_faces; ++f)
        centroids[static_cast<std::size_t>(f)]
            = (m_positions.row(m_faces(f, 0)) + m_positions.row(m_faces(f, 1))
                  + m_positions.row(m_faces(f, 2)))
                  .transpose()
            / 3.0;
    m_order.resize(static_cast<std::size_t>(num_faces));
    std::iota(m_order.begin(), m_order.end(), 0);
    m_nodes.reserve(static_cast<std::size_t>(2 * num_faces / k_leaf_size + 2));
    build(0, static_cast<int>(num_faces), centroids);
}

int SurfaceDistance::build(int begin, int end, const std::vector<Vec3>& centroids)
{
    const int index = static_cast<int>(m_nodes.size());
    m_nodes.emplace_back();
    Box3 box, centroid_box;
    for (int i = begin; i < end; ++i) {
        const int f = m_order[static_cast<std::size_t>(i)];
        for (int k = 0; k < 3; ++k)
            box.extend(m_positions.row(m_faces(f, k)).transpose());
        centroid_box.extend(centroids[static_cast<std::size_t>(f)]);
    }
    m_nodes[static_cast<std::size_t>(index)].box = box;
    if (end - begin <= k_leaf_size) {
        m_nodes[static_cast<std::size_t>(index)].first = begin;
        m_nodes[static_cast<std::size_t>(index)].count = end - begin;
        return index;
    }
    int axis = 0;
    centroid_box.diagonal().maxCoeff(&axis);
    const int middle = begin + (end - begin) / 2;
    std::nth_element(m_order.begin() + begin, m_order.begin() + middle, m_order.begin() + end,
        [&](int a, int b) {
            const double ca = centroids[static_cast<std::size_t>(a)](axis);
            const double cb = centroids[static_cast<std::size_t>(b)](axis);
            return ca < cb || (ca == cb && a < b);
        });
    const int left = build(begin, middle, centroids);
    const int right = build(middle, end, centroids);
    m_nodes[static_cast<std::size_t>(index)].first = left;
    m_nodes[static_cast<std::size_t>(index)].count = 0;
    m_nodes[static_cast<std::size_t>(index)].right = right;
    return index;
}

// Closest point on a triangle by Voronoi regions of its features (Ericson, Real-Time Collision
// Detection, 2005, section 5.1.5).
Vec3 SurfaceDistance::closest_on_face(Index f, const Vec3& p, int& feature) const
{
    const Vec3 a = m_positions.row(m_faces(f, 0));
    const Vec3 b = m_positions.row(m_faces(f, 1));
    const Vec3 c = m_positions.row(m_faces(f, 2));
    const Vec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) {
        feature = 0;
        return a;
    }
    const Vec3 bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) {
        feature = 1;
        return b;
    }
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        feature = 3;
        return a + (d1 / (d1 - d3)) * ab;
    }
    const Vec3 cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) {
        feature = 2;
        return c;
    }
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        feature = 5;
        return a + (d2 / (d2 - d6)) * ac;
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        feature = 4;
        return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    }
    const double denominator = va + vb + vc;
    if (!(std::abs(denominator) > 0)) { // degenerate face: fall back to its vertex a
        feature = 0;
        return a;
    }
    feature = 6;
    return a + (vb / denominator) * ab + (vc / denominator) * ac;
}

void SurfaceDistance::search(const Vec3& p, double& best_squared, Index& best_face,
    Vec3& best_point, int& best_feature) const
{
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& node = m_nodes[static_cast<std::size_t>(stack[--top])];
        if (box_squared_distance(node.box, p) >= best_squared)
            continue;
        if (node.count > 0) {
            for (int i = node.first; i < node.first + node.count; ++i) {
                const int f = m_order[static_cast<std::size_t>(i)];
                int feature = 0;
                const Vec3 q = closest_on_face(f, p, feature);
                const double squared = (q - p).squaredNorm();
                if (squared < best_squared || (squared == best_squared && f < best_face)) {
                    best_squared = squared;
                    best_face = f;
                    best_point = q;
                    best_feature = feature;
                }
            }
            continue;
        }
        const int left = node.first;
        const int right_child = node.right;
        const double dl = box_squared_distance(m_nodes[static_cast<std::size_t>(left)].box, p);
        const double dr
            = box_squared_distance(m_nodes[static_cast<std::size_t>(right_child)].box, p);
        // Visit the nearer child first (pushed last).
        if (dl <= dr) {
            stack[top++] = right_child;
            stack[top++] = left;
        } else {
            stack[top++] = left;
            stack[top++] = right_child;
        }
    }
}

SurfaceClosestPoint SurfaceDistance::closest(const Eigen::Ref<const Vec3>& p) const
{
    double best_squared = std::numeric_limits<double>::infinity();
    SurfaceClosestPoint result;
    int feature = 0;
    search(p, best_squared, result.face, result.point, feature);
    result.distance = std::sqrt(best_squared);
    return result;
}

double SurfaceDistance::unsigned_distance(const Eigen::Ref<const Vec3>& p) const
{
    return closest(p).distance;
}

double SurfaceDistance::signed_distance(const Eigen::Ref<const Vec3>& p) const
{
    double best_squared = std::numeric_limits<double>::infinity();
    Index face = -1;
    Vec3 point = Vec3::Zero();
    int feature = 0;
    search(p, best_squared, face, point, feature);
    Vec3 normal;
    if (feature < 3)
        normal = m_vertex_normals.row(m_faces(face, feature)).transpose();
    else if (feature < 6)
        normal = m_edge_normals.row(3 * face + (feature - 3)).transpose();
    else
        normal = m_face_normals.row(face).transpose();
    const double distance = std::sqrt(best_squared);
    return (p - point).dot(normal) < 0 ? -distance : distance;
}

bool SurfaceDistance::any_within(const Eigen::Ref<const Vec3>& point, double radius) const
{
    const Vec3 p = point;
    const double squared = radius * radius;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& node = m_nodes[static_cast<std::size_t>(stack[--top])];
        if (box_squared_distance(node.box, p) > squared)
            continue;
        if (node.count == 0) {
            stack[top++] = node.right;
            stack[top++] = node.first;
            continue;
        }
        for (int i = node.first; i < node.first + node.count; ++i) {
            int feature = 0;
            if ((closest_on_face(m_order[static_cast<std::size_t>(i)], p, feature) - p)
                    .squaredNorm()
                <= squared)
                return true;
        }
    }
    return false;
}

} // namespace mat
