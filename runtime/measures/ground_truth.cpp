// Sort and sweep in columns. A plain sweep along one axis meets, for each triangle of a surface,
// every triangle of the ring that its box's slab cuts from the surface (about sqrt(F) of them).
// So the plane across the sweep axis is cut into a grid of square columns of about two median
// triangle sizes (at most one column per triangle, so memory follows the triangle count and not
// the extent of the scene); each triangle enters every column its box meets, each column is
// swept on its own, and a pair that shares several columns is tested only in the column that
// holds the low corner of the intersection of the two boxes' cross-sections. A triangle whose
// box meets more than max_columns columns is oversize: it is swept against every triangle.

#include "runtime/measures/ground_truth.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "runtime/collision/triangle_tests.hpp"

namespace mat {

namespace {

    constexpr std::size_t max_columns = 64;
    constexpr std::size_t columns_per_task = 256;

    void validate(const std::vector<SurfaceMesh>& surfaces)
    {
        for (std::size_t s = 0; s < surfaces.size(); ++s) {
            const SurfaceMesh& mesh = surfaces[s];
            for (Index v = 0; v < mesh.num_vertices(); ++v)
                if (!mesh.positions.row(v).allFinite())
                    throw_error(
                        "ground truth: surface {} vertex {} has a non-finite coordinate", s, v);
            for (Index f = 0; f < mesh.num_faces(); ++f)
                for (int k = 0; k < 3; ++k) {
                    const int v = mesh.faces(f, k);
                    if (v < 0 || v >= mesh.num_vertices())
                        throw_error("ground truth: surface {} face {} has vertex index {} outside "
                                    "[0, {})",
                            s, f, v, mesh.num_vertices());
                }
        }
    }

    bool share_vertex(const MatX3i& faces, int f, int g)
    {
        for (int k = 0; k < 3; ++k)
            for (int l = 0; l < 3; ++l)
                if (faces(f, k) == faces(g, l))
                    return true;
        return false;
    }

    // A triangle's box in sweep-axis-first coordinates, as the sweep reads it.
    struct SweepBox {
        double lo0, hi0, lo1, hi1, lo2, hi2;
        int triangle;
        int column1; ///< first column covered across axis 1
        int column2; ///< first column covered across axis 2
    };

    bool cross_sections_overlap(const SweepBox& a, const SweepBox& b)
    {
        return a.lo1 <= b.hi1 && b.lo1 <= a.hi1 && a.lo2 <= b.hi2 && b.lo2 <= a.hi2;
    }

    // Columns along one axis: [origin + i width, origin + (i + 1) width), the ends unbounded.
    struct ColumnAxis {
        double origin = 0.0;
        double width = 1.0;
        int count = 1;

        int of(double v) const
        {
            if (count == 1)
                return 0;
            const double i = std::floor((v - origin) / width);
            if (!(i > 0.0))
                return 0;
            return i >= count - 1 ? count - 1 : static_cast<int>(i);
        }
    };

} // namespace

std::vector<TrianglePair> intersecting_triangle_pairs(
    const std::vector<SurfaceMesh>& surfaces, const GroundTruthOptions& options)
{
    validate(surfaces);

    // Every triangle of every surface, numbered surface after surface.
    struct Triangle {
        int body;
        int face;
    };
    std::vector<Triangle> triangles;
    Box3 scene;
    for (std::size_t s = 0; s < surfaces.size(); ++s) {
        for (Index f = 0; f < surfaces[s].num_faces(); ++f)
            triangles.push_back({ static_cast<int>(s), static_cast<int>(f) });
        for (Index v = 0; v < surfaces[s].num_vertices(); ++v)
            scene.extend(surfaces[s].positions.row(v).transpose());
    }
    const std::size_t n = triangles.size();
    if (n < 2)
        return {};
    const auto corner = [&](const Triangle& t, int k) -> Vec3 {
        const SurfaceMesh& mesh = surfaces[static_cast<std::size_t>(t.body)];
        return mesh.positions.row(mesh.faces(t.face, k)).transpose();
    };

    // The sweep runs along the longest axis of the scene; the columns cut the other two.
    std::array<int, 3> axes = { 0, 1, 2 };
    const Vec3 sizes = scene.sizes();
    std::sort(axes.begin(), axes.end(), [&](int i, int j) { return sizes[i] > sizes[j]; });
    std::vector<SweepBox> boxes(n);
    tbb::parallel_for(std::size_t { 0 }, n, [&](std::size_t i) {
        Box3 box(corner(triangles[i], 0));
        box.extend(corner(triangles[i], 1));
        box.extend(corner(triangles[i], 2));
        boxes[i] = { box.min()[axes[0]], box.max()[axes[0]], box.min()[axes[1]], box.max()[axes[1]],
            box.min()[axes[2]], box.max()[axes[2]], static_cast<int>(i), 0, 0 };
    });

    // Column width: twice the median cross-section size, widened until there are at most n
    // columns.
    std::vector<double> extents(n);
    for (std::size_t i = 0; i < n; ++i)
        extents[i] = std::max(boxes[i].hi1 - boxes[i].lo1, boxes[i].hi2 - boxes[i].lo2);
    std::nth_element(
        extents.begin(), extents.begin() + static_cast<std::ptrdiff_t>(n / 2), extents.end());
    double width = 2.0 * extents[n / 2];
    if (!(width > 0.0))
        width = std::max(sizes[axes[1]], sizes[axes[2]]) / std::sqrt(static_cast<double>(n));
    const auto column_count
        = [&](double span) { return width > 0.0 ? std::max(1.0, std::ceil(span / width)) : 1.0; };
    while (column_count(sizes[axes[1]]) * column_count(sizes[axes[2]]) > static_cast<double>(n))
        width *= 1.5;
    ColumnAxis across1 { scene.min()[axes[1]], width,
        static_cast<int>(column_count(sizes[axes[1]])) };
    ColumnAxis across2 { scene.min()[axes[2]], width,
        static_cast<int>(column_count(sizes[axes[2]])) };
    const std::size_t columns = static_cast<std::size_t>(across1.count) * across2.count;

    // Each column's entries (a counting sort by column); each column is put in sweep order
    // when it is swept.
    std::vector<std::size_t> column_start(columns + 1, 0);
    std::vector<char> oversize(n, 0);
    std::vector<std::size_t> oversize_triangles;
    for (std::size_t i = 0; i < n; ++i) {
        SweepBox& box = boxes[i];
        box.column1 = across1.of(box.lo1);
        box.column2 = across2.of(box.lo2);
        const int end1 = across1.of(box.hi1);
        const int end2 = across2.of(box.hi2);
        const auto covered = static_cast<std::size_t>(end1 - box.column1 + 1)
            * static_cast<std::size_t>(end2 - box.column2 + 1);
        if (covered > max_columns) {
            oversize[i] = 1;
            oversize_triangles.push_back(i);
            continue;
        }
        for (int c2 = box.column2; c2 <= end2; ++c2)
            for (int c1 = box.column1; c1 <= end1; ++c1)
                ++column_start[static_cast<std::size_t>(c2) * across1.count + c1 + 1];
    }
    std::partial_sum(column_start.begin(), column_start.end(), column_start.begin());
    std::vector<SweepBox> entries(column_start.back());
    {
        std::vector<std::size_t> fill(column_start.begin(), column_start.end() - 1);
        for (std::size_t i = 0; i < n; ++i) {
            if (oversize[i])
                continue;
            const SweepBox& box = boxes[i];
            const int end1 = across1.of(box.hi1);
            const int end2 = across2.of(box.hi2);
            for (int c2 = box.column2; c2 <= end2; ++c2)
                for (int c1 = box.column1; c1 <= end1; ++c1)
                    entries[fill[static_cast<std::size_t>(c2) * across1.count + c1]++] = box;
        }
    }

    // The exact test of one pair whose boxes overlap, after the adjacency and option filters.
    const auto test = [&](int ta, int tb, std::vector<TrianglePair>& out) {
        const Triangle& a = triangles[static_cast<std::size_t>(ta)];
        const Triangle& b = triangles[static_cast<std::size_t>(tb)];
        if (a.body == b.body) {
            if (!options.self_pairs
                || share_vertex(surfaces[static_cast<std::size_t>(a.body)].faces, a.face, b.face))
                return;
        } else if (!options.object_pairs) {
            return;
        }
        if (!triangles_intersect(
                corner(a, 0), corner(a, 1), corner(a, 2), corner(b, 0), corner(b, 1), corner(b, 2)))
            return;
        if (std::make_pair(b.body, b.face) < std::make_pair(a.body, a.face))
            out.push_back({ b.body, b.face, a.body, a.face });
        else
            out.push_back({ a.body, a.face, b.body, b.face });
    };

    const std::size_t tasks = (columns + columns_per_task - 1) / columns_per_task;
    std::vector<std::vector<TrianglePair>> found(tasks + oversize_triangles.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tasks, 1), [&](const auto& range) {
        for (std::size_t task = range.begin(); task < range.end(); ++task) {
            const std::size_t last = std::min(columns, (task + 1) * columns_per_task);
            for (std::size_t column = task * columns_per_task; column < last; ++column) {
                const int c1 = static_cast<int>(column % static_cast<std::size_t>(across1.count));
                const int c2 = static_cast<int>(column / static_cast<std::size_t>(across1.count));
                SweepBox* begin = entries.data() + column_start[column];
                SweepBox* end = entries.data() + column_start[column + 1];
                std::sort(begin, end, [](const SweepBox& a, const SweepBox& b) {
                    return a.lo0 < b.lo0 || (a.lo0 == b.lo0 && a.triangle < b.triangle);
                });
                for (const SweepBox* a = begin; a != end; ++a)
                    for (const SweepBox* b = a + 1; b != end && b->lo0 <= a->hi0; ++b)
                        if (cross_sections_overlap(*a, *b) && std::max(a->column1, b->column1) == c1
                            && std::max(a->column2, b->column2) == c2)
                            test(a->triangle, b->triangle, found[task]);
            }
        }
    });
    // Oversize triangles against every box that meets theirs (an oversize pair once, from the
    // lower triangle index).
    tbb::parallel_for(std::size_t { 0 }, oversize_triangles.size(), [&](std::size_t k) {
        const SweepBox& a = boxes[oversize_triangles[k]];
        for (std::size_t i = 0; i < n; ++i) {
            const SweepBox& b = boxes[i];
            if (b.triangle == a.triangle || b.lo0 > a.hi0 || b.hi0 < a.lo0
                || !cross_sections_overlap(a, b) || (oversize[i] && b.triangle < a.triangle))
                continue;
            test(a.triangle, b.triangle, found[tasks + k]);
        }
    });

    std::vector<TrianglePair> out;
    for (const auto& part : found)
        out.insert(out.end(), part.begin(), part.end());
    std::sort(out.begin(), out.end());
    return out;
}

} // namespace mat
