#include "preprocess/embedding/tet_embedding.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"

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

    // A uniform grid over the mesh bounding box; each cell lists the tets whose boxes overlap it.
    class TetGrid {
    public:
        TetGrid(const TetMesh& mesh)
            : m_mesh(mesh)
        {
            const Index num_tets = mesh.num_tets();
            for (Index v = 0; v < mesh.num_vertices(); ++v)
                m_box.extend(mesh.positions.row(v).transpose());
            // About 2 tets per cell on average.
            const double volume = std::max(m_box.volume(), 1e-300);
            const double cell = std::cbrt(volume * 2.0 / std::max<Index>(num_tets, 1));
            m_cell = std::max(cell, 1e-12 * std::max(m_box.diagonal().norm(), 1e-300));
            for (int a = 0; a < 3; ++a)
                m_dims[a]
                    = std::max<Index>(1, static_cast<Index>(std::ceil(m_box.sizes()(a) / m_cell)));
            const Index num_cells = m_dims[0] * m_dims[1] * m_dims[2];
            m_start.assign(static_cast<size_t>(num_cells + 1), 0);
            // Two passes: count, then fill (CSR).
            for (int pass = 0; pass < 2; ++pass) {
                std::vector<Index> cursor;
                if (pass == 1) {
                    for (Index i = 0; i < num_cells; ++i)
                        m_start[static_cast<size_t>(i + 1)] += m_start[static_cast<size_t>(i)];
                    cursor.assign(m_start.begin(), m_start.end() - 1);
                    m_items.resize(static_cast<size_t>(m_start.back()));
                }
                for (Index t = 0; t < num_tets; ++t) {
                    Box3 box;
                    for (int k = 0; k < 4; ++k)
                        box.extend(mesh.positions.row(mesh.tets(t, k)).transpose());
                    const auto lo = cell_of(box.min()), hi = cell_of(box.max());
                    for (Index i = lo[0]; i <= hi[0]; ++i)
                        for (Index j = lo[1]; j <= hi[1]; ++j)
                            for (Index k = lo[2]; k <= hi[2]; ++k) {
                                const Index id = (i * m_dims[1] + j) * m_dims[2] + k;
                                if (pass == 0)
                                    ++m_start[static_cast<size_t>(id + 1)];
                                else
                                    m_items[static_cast<size_t>(cursor[static_cast<size_t>(id)]++)]
                                        = static_cast<int>(t);
                            }
                }
            }
        }

        std::array<Index, 3> cell_of(const Vec3& p) const
        {
            std::array<Index, 3> c;
            for (int a = 0; a < 3; ++a)
                c[a] = std::clamp<Index>(
                    static_cast<Index>(std::floor((p(a) - m_box.min()(a)) / m_cell)), 0,
                    m_dims[a] - 1);
            return c;
        }

        // Calls visit(tet) for the tets listed in the cells within `ring` cells of p's cell.
        template <typename Visit> void visit_ring(const Vec3& p, Index ring, Visit&& visit) const
        {
            const auto c = cell_of(p);
            for (Index i = std::max<Index>(0, c[0] - ring);
                 i <= std::min(m_dims[0] - 1, c[0] + ring); ++i)
                for (Index j = std::max<Index>(0, c[1] - ring);
                     j <= std::min(m_dims[1] - 1, c[1] + ring); ++j)
                    for (Index k = std::max<Index>(0, c[2] - ring);
                         k <= std::min(m_dims[2] - 1, c[2] + ring); ++k) {
                        const Index id = (i * m_dims[1] + j) * m_dims[2] + k;
                        for (Index s = m_start[static_cast<size_t>(id)];
                             s < m_start[static_cast<size_t>(id + 1)]; ++s)
                            visit(m_items[static_cast<size_t>(s)]);
                    }
        }

        double cell_size() const { return m_cell; }
        Index max_dim() const { return std::max({ m_dims[0], m_dims[1], m_dims[2] }); }

    private:
        const TetMesh& m_mesh;
        Box3 m_box;
        double m_cell = 1.0;
        std::array<Index, 3> m_dims { 1, 1, 1 };
        std::vector<Index> m_start;
        std::vector<int> m_items;
    };

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

TetEmbedding embed_points(const TetMesh& mesh, const Eigen::Ref<const MatX3>& points)
{
    if (mesh.num_tets() == 0)
        throw_error("cannot embed points: the tet mesh has no tets");
    const TetGrid grid(mesh);
    const Index num_points = points.rows();
    TetEmbedding result;
    result.tet.resize(num_points);
    result.barycentric.resize(num_points, 4);
    std::vector<double> outside_distance(static_cast<size_t>(num_points), 0.0);

    auto corner = [&](Index t, int k) { return mesh.positions.row(mesh.tets(t, k)).transpose(); };

    tbb::parallel_for(Index(0), num_points, [&](Index p) {
        const Vec3 x = points.row(p).transpose();
        // Inside: the tet of the point's cell where the smallest barycentric is largest.
        int best = -1;
        double best_min = -std::numeric_limits<double>::infinity();
        Vec4 best_bary = Vec4::Zero();
        grid.visit_ring(x, 0, [&](int t) {
            const Vec4 bary
                = tet_barycentric(corner(t, 0), corner(t, 1), corner(t, 2), corner(t, 3), x);
            if (bary.minCoeff() > best_min || (bary.minCoeff() == best_min && t < best)) {
                best_min = bary.minCoeff();
                best = t;
                best_bary = bary;
            }
        });
        const double inside_tolerance = -1e-12;
        if (best >= 0 && best_min >= inside_tolerance) {
            result.tet(p) = best;
            result.barycentric.row(p) = best_bary.transpose();
            return;
        }
        // Outside: the nearest tet, searching growing rings of cells until the ring is farther
        // than the best distance found.
        double best_distance = std::numeric_limits<double>::infinity();
        best = -1;
        for (Index ring = 0; ring <= grid.max_dim(); ++ring) {
            grid.visit_ring(x, ring, [&](int t) {
                const double dist
                    = point_tet_distance(corner(t, 0), corner(t, 1), corner(t, 2), corner(t, 3), x);
                if (dist < best_distance || (dist == best_distance && t < best)) {
                    best_distance = dist;
                    best = t;
                }
            });
            // Tets not yet visited lie in cells beyond this ring: at least ring cells from x.
            if (best >= 0 && best_distance <= ring * grid.cell_size())
                break;
        }
        result.tet(p) = best;
        result.barycentric.row(p)
            = tet_barycentric(corner(best, 0), corner(best, 1), corner(best, 2), corner(best, 3), x)
                  .transpose();
        outside_distance[static_cast<size_t>(p)] = std::max(best_distance, 1e-300);
    });
    for (double d : outside_distance)
        if (d > 0) {
            ++result.outside_count;
            result.max_outside_distance = std::max(result.max_outside_distance, d);
        }
    return result;
}

} // namespace mat
