#include "preprocess/embedding/tet_embedding.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "preprocess/embedding/box_grid.hpp"

namespace mat {

Vec4 tet_barycentric(const Eigen::Ref<const Vec3>& a, const Eigen::Ref<const Vec3>& b,
    const Eigen::Ref<const Vec3>& c, const Eigen::Ref<const Vec3>& d,
    const Eigen::Ref<const Vec3>& p)
{
    Mat3 edges;
    edges.col(0) = b - a;
    edges.col(1) = c - a;
    edges.col(2) = d - a;
    const Vec3 local = edges.partialPivLu().solve(p - a);
    return Vec4(1.0 - local.sum(), local(0), local(1), local(2));
}

namespace {

    // Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
    Vec3 closest_on_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c)
    {
        const Vec3 ab = b - a, ac = c - a, ap = p - a;
        const double d1 = ab.dot(ap), d2 = ac.dot(ap);
        if (d1 <= 0 && d2 <= 0)
            return a;
        const Vec3 bp = p - b;
        const double d3 = ab.dot(bp), d4 = ac.dot(bp);
        if (d3 >= 0 && d4 <= d3)
            return b;
        const double vc = d1 * d4 - d3 * d2;
        if (vc <= 0 && d1 >= 0 && d3 <= 0)
            return a + ab * (d1 / (d1 - d3));
        const Vec3 cp = p - c;
        const double d5 = ab.dot(cp), d6 = ac.dot(cp);
        if (d6 >= 0 && d5 <= d6)
            return c;
        const double vb = d5 * d2 - d1 * d6;
        if (vb <= 0 && d2 >= 0 && d6 <= 0)
            return a + ac * (d2 / (d2 - d6));
        const double va = d3 * d6 - d5 * d4;
        if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
            return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
        const double denom = 1.0 / (va + vb + vc);
        return a + ab * (vb * denom) + ac * (vc * denom);
    }

} // namespace

double point_tet_distance(const Eigen::Ref<const Vec3>& a, const Eigen::Ref<const Vec3>& b,
    const Eigen::Ref<const Vec3>& c, const Eigen::Ref<const Vec3>& d,
    const Eigen::Ref<const Vec3>& p)
{
    const Vec4 bary = tet_barycentric(a, b, c, d, p);
    if (bary.minCoeff() >= 0)
        return 0.0;
    const Vec3 pts[4] = { a, b, c, d };
    const Vec3 point = p;
    double best = std::numeric_limits<double>::infinity();
    static constexpr int faces[4][3] = { { 1, 2, 3 }, { 0, 2, 3 }, { 0, 1, 3 }, { 0, 1, 2 } };
    for (const auto& f : faces)
        best = std::min(
            best, (closest_on_triangle(point, pts[f[0]], pts[f[1]], pts[f[2]]) - point).norm());
    return best;
}

namespace {

    // Corner k of tet t.
    auto tet_corner(const TetMesh& mesh, Index t, int k)
    {
        return mesh.positions.row(mesh.tets(t, k)).transpose();
    }

    // Barycentric coordinates of x in tet t.
    Vec4 barycentric_in(const TetMesh& mesh, Index t, const Vec3& x)
    {
        return tet_barycentric(tet_corner(mesh, t, 0), tet_corner(mesh, t, 1),
            tet_corner(mesh, t, 2), tet_corner(mesh, t, 3), x);
    }

    // A grid over the tets' bounding boxes, for inside queries.
    BoxGrid tet_box_grid(const TetMesh& mesh)
    {
        std::vector<Box3> tet_boxes(static_cast<size_t>(mesh.num_tets()));
        for (Index t = 0; t < mesh.num_tets(); ++t)
            for (int k = 0; k < 4; ++k)
                tet_boxes[static_cast<size_t>(t)].extend(tet_corner(mesh, t, k));
        return BoxGrid(tet_boxes);
    }

    /// A face of one tet only: its sorted vertices, the tet, and the face's index in the tet.
    struct BoundaryFace {
        std::array<int, 3> key;
        int tet;
        int face;
    };

    // The mesh's boundary faces (faces of one tet only), sorted by key.
    std::vector<BoundaryFace> boundary_faces(const TetMesh& mesh)
    {
        static constexpr int face_corners[4][3]
            = { { 1, 2, 3 }, { 0, 2, 3 }, { 0, 1, 3 }, { 0, 1, 2 } };
        std::vector<BoundaryFace> faces;
        faces.reserve(static_cast<size_t>(4 * mesh.num_tets()));
        for (Index t = 0; t < mesh.num_tets(); ++t)
            for (int f = 0; f < 4; ++f) {
                std::array<int, 3> key;
                for (int k = 0; k < 3; ++k)
                    key[static_cast<size_t>(k)] = mesh.tets(t, face_corners[f][k]);
                std::sort(key.begin(), key.end());
                faces.push_back({ key, static_cast<int>(t), f });
            }
        std::sort(faces.begin(), faces.end(), [](const BoundaryFace& a, const BoundaryFace& b) {
            return a.key < b.key || (a.key == b.key && a.tet < b.tet);
        });
        std::vector<BoundaryFace> boundary;
        for (size_t i = 0; i < faces.size();) {
            size_t j = i;
            while (j < faces.size() && faces[j].key == faces[i].key)
                ++j;
            if (j - i == 1)
                boundary.push_back(faces[i]);
            i = j;
        }
        return boundary;
    }

    // A grid over the boundary faces' bounding boxes, for outside queries.
    BoxGrid face_box_grid(const TetMesh& mesh, const std::vector<BoundaryFace>& boundary)
    {
        std::vector<Box3> face_boxes(boundary.size());
        for (size_t b = 0; b < boundary.size(); ++b)
            for (int k = 0; k < 3; ++k)
                face_boxes[b].extend(
                    mesh.positions.row(boundary[b].key[static_cast<size_t>(k)]).transpose());
        return BoxGrid(face_boxes);
    }

    // Inside: the tet of x's cell where the smallest barycentric is largest (ties: the lower
    // tet), or -1 if no tet holds x to the inside tolerance.
    int enclosing_tet(const TetMesh& mesh, const BoxGrid& tet_grid, const Vec3& x, Vec4& bary_out)
    {
        int best = -1;
        double best_min = -std::numeric_limits<double>::infinity();
        Vec4 best_bary = Vec4::Zero();
        tet_grid.visit_shell(x, 0, [&](int t) {
            const Vec4 bary = barycentric_in(mesh, t, x);
            if (bary.minCoeff() > best_min || (bary.minCoeff() == best_min && t < best)) {
                best_min = bary.minCoeff();
                best = t;
                best_bary = bary;
            }
        });
        const double inside_tolerance = -1e-12;
        if (best >= 0 && best_min >= inside_tolerance) {
            bary_out = best_bary;
            return best;
        }
        return -1;
    }

    // Outside: the nearest boundary face to x (ties: the lower face), searching shells of cells
    // outward until the next shell is farther than the best distance found; writes the distance.
    int nearest_boundary_face(const TetMesh& mesh, const std::vector<BoundaryFace>& boundary,
        const BoxGrid& face_grid, const Vec3& x, double& distance)
    {
        double best_distance = std::numeric_limits<double>::infinity();
        int best_face = -1;
        for (Index ring = 0; ring <= face_grid.max_ring(); ++ring) {
            face_grid.visit_shell(x, ring, [&](int b) {
                const auto& key = boundary[static_cast<size_t>(b)].key;
                const double dist = (closest_on_triangle(x, mesh.positions.row(key[0]).transpose(),
                                         mesh.positions.row(key[1]).transpose(),
                                         mesh.positions.row(key[2]).transpose())
                    - x)
                                        .norm();
                if (dist < best_distance || (dist == best_distance && b < best_face)) {
                    best_distance = dist;
                    best_face = b;
                }
            });
            if (best_face >= 0 && best_distance <= ring * face_grid.cell_size())
                break;
        }
        distance = best_distance;
        return best_face;
    }

    /// The tets around each node (CSR over the node indices, tets increasing).
    struct NodeTets {
        std::vector<int> indptr;
        std::vector<int> tets;
    };

    NodeTets node_tets(const TetMesh& mesh)
    {
        NodeTets result;
        result.indptr.assign(static_cast<size_t>(mesh.num_vertices()) + 1, 0);
        for (Index t = 0; t < mesh.num_tets(); ++t)
            for (int k = 0; k < 4; ++k)
                ++result.indptr[static_cast<size_t>(mesh.tets(t, k)) + 1];
        for (size_t i = 1; i < result.indptr.size(); ++i)
            result.indptr[i] += result.indptr[i - 1];
        result.tets.resize(static_cast<size_t>(result.indptr.back()));
        std::vector<int> fill(result.indptr.begin(), result.indptr.end() - 1);
        for (Index t = 0; t < mesh.num_tets(); ++t)
            for (int k = 0; k < 4; ++k)
                result.tets[static_cast<size_t>(fill[static_cast<size_t>(mesh.tets(t, k))]++)]
                    = static_cast<int>(t);
        return result;
    }

    /// Outside: among the tets around the corners of the nearest boundary face, the one whose
    /// smallest barycentric coordinate of x is largest (ties: the lower tet), the least
    /// extrapolated (docs/method.md, section 2, step 2).
    int least_extrapolated_tet(
        const TetMesh& mesh, const NodeTets& around, const BoundaryFace& face, const Vec3& x)
    {
        int best = face.tet;
        double best_min = barycentric_in(mesh, face.tet, x).minCoeff();
        for (const int node : face.key)
            for (int i = around.indptr[static_cast<size_t>(node)];
                 i < around.indptr[static_cast<size_t>(node) + 1]; ++i) {
                const int t = around.tets[static_cast<size_t>(i)];
                const double m = barycentric_in(mesh, t, x).minCoeff();
                if (m > best_min || (m == best_min && t < best)) {
                    best_min = m;
                    best = t;
                }
            }
        return best;
    }

} // namespace

TetEmbedding embed_points(const TetMesh& mesh, const Eigen::Ref<const MatX3>& points)
{
    if (mesh.num_tets() == 0)
        throw_error("cannot embed points: the tet mesh has no tets");

    // Inside queries: a grid over the tets. Outside queries: a grid over the boundary faces
    // (faces of one tet only), since the nearest point of the mesh lies on its boundary.
    const BoxGrid tet_grid = tet_box_grid(mesh);
    const std::vector<BoundaryFace> boundary = boundary_faces(mesh);
    const BoxGrid face_grid = face_box_grid(mesh, boundary);
    const NodeTets around = node_tets(mesh);

    const Index num_points = points.rows();
    TetEmbedding result;
    result.tet.resize(num_points);
    result.barycentric.resize(num_points, 4);
    std::vector<double> outside_distance(static_cast<size_t>(num_points), 0.0);

    tbb::parallel_for(Index(0), num_points, [&](Index p) {
        const Vec3 x = points.row(p).transpose();
        Vec4 bary;
        const int inside = enclosing_tet(mesh, tet_grid, x, bary);
        if (inside >= 0) {
            result.tet(p) = inside;
            result.barycentric.row(p) = bary.transpose();
            return;
        }
        double distance = 0.0;
        const int face = nearest_boundary_face(mesh, boundary, face_grid, x, distance);
        const int best
            = least_extrapolated_tet(mesh, around, boundary[static_cast<size_t>(face)], x);
        result.tet(p) = best;
        result.barycentric.row(p) = barycentric_in(mesh, best, x).transpose();
        outside_distance[static_cast<size_t>(p)] = std::max(distance, 1e-300);
    });
    for (double d : outside_distance)
        if (d > 0) {
            ++result.outside_count;
            result.max_outside_distance = std::max(result.max_outside_distance, d);
        }
    return result;
}

} // namespace mat
