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

    // A triangle: its surface and its face there.
    struct Triangle {
        int body;
        int face;
    };

    Vec3 corner(const std::vector<SurfaceMesh>& surfaces, const Triangle& t, int k)
    {
        const SurfaceMesh& mesh = surfaces[static_cast<std::size_t>(t.body)];
        return mesh.positions.row(mesh.faces(t.face, k)).transpose();
    }

    // Every triangle of every surface, numbered surface after surface; `scene`: the box of every
    // vertex.
    std::vector<Triangle> list_triangles(const std::vector<SurfaceMesh>& surfaces, Box3& scene)
    {
        std::vector<Triangle> triangles;
        for (std::size_t s = 0; s < surfaces.size(); ++s) {
            for (Index f = 0; f < surfaces[s].num_faces(); ++f)
                triangles.push_back({ static_cast<int>(s), static_cast<int>(f) });
            for (Index v = 0; v < surfaces[s].num_vertices(); ++v)
                scene.extend(surfaces[s].positions.row(v).transpose());
        }
        return triangles;
    }

    // The triangles' boxes in sweep-axis-first coordinates (in parallel).
    std::vector<SweepBox> sweep_boxes(const std::vector<SurfaceMesh>& surfaces,
        const std::vector<Triangle>& triangles, const std::array<int, 3>& axes)
    {
        std::vector<SweepBox> boxes(triangles.size());
        tbb::parallel_for(std::size_t { 0 }, triangles.size(), [&](std::size_t i) {
            Box3 box(corner(surfaces, triangles[i], 0));
            box.extend(corner(surfaces, triangles[i], 1));
            box.extend(corner(surfaces, triangles[i], 2));
            boxes[i]
                = { box.min()[axes[0]], box.max()[axes[0]], box.min()[axes[1]], box.max()[axes[1]],
                      box.min()[axes[2]], box.max()[axes[2]], static_cast<int>(i), 0, 0 };
        });
        return boxes;
    }

    // Columns of `width` over `span` (at least 1).
    double column_count(double span, double width)
    {
        return width > 0.0 ? std::max(1.0, std::ceil(span / width)) : 1.0;
    }

    // Column width: twice the median cross-section size, widened until there are at most as
    // many columns as boxes.
    double column_width(
        const std::vector<SweepBox>& boxes, const Vec3& sizes, const std::array<int, 3>& axes)
    {
        const std::size_t n = boxes.size();
        std::vector<double> extents(n);
        for (std::size_t i = 0; i < n; ++i)
            extents[i] = std::max(boxes[i].hi1 - boxes[i].lo1, boxes[i].hi2 - boxes[i].lo2);
        std::nth_element(
            extents.begin(), extents.begin() + static_cast<std::ptrdiff_t>(n / 2), extents.end());
        double width = 2.0 * extents[n / 2];
        if (!(width > 0.0))
            width = std::max(sizes[axes[1]], sizes[axes[2]]) / std::sqrt(static_cast<double>(n));
        while (column_count(sizes[axes[1]], width) * column_count(sizes[axes[2]], width)
            > static_cast<double>(n))
            width *= 1.5;
        return width;
    }

    // The boxes filed by column: each box in every column it meets, but an oversize one.
    struct Columns {
        ColumnAxis across1, across2;
        std::size_t count = 0; ///< across1.count x across2.count
        std::vector<std::size_t> start; ///< count + 1, CSR into `entries`
        std::vector<SweepBox> entries;
        std::vector<char> oversize; ///< per box
        std::vector<std::size_t> oversize_triangles; ///< increasing
    };

    // Files `boxes` in the columns of `columns` (a counting sort by column; each column is put in
    // sweep order when it is swept), and sets each box's first columns.
    void file_in_columns(std::vector<SweepBox>& boxes, Columns& columns)
    {
        const ColumnAxis& across1 = columns.across1;
        const ColumnAxis& across2 = columns.across2;
        const std::size_t n = boxes.size();
        std::vector<std::size_t>& column_start = columns.start;
        column_start.assign(columns.count + 1, 0);
        columns.oversize.assign(n, 0);
        for (std::size_t i = 0; i < n; ++i) {
            SweepBox& box = boxes[i];
            box.column1 = across1.of(box.lo1);
            box.column2 = across2.of(box.lo2);
            const int end1 = across1.of(box.hi1);
            const int end2 = across2.of(box.hi2);
            const auto covered = static_cast<std::size_t>(end1 - box.column1 + 1)
                * static_cast<std::size_t>(end2 - box.column2 + 1);
            if (covered > max_columns) {
                columns.oversize[i] = 1;
                columns.oversize_triangles.push_back(i);
                continue;
            }
            for (int c2 = box.column2; c2 <= end2; ++c2)
                for (int c1 = box.column1; c1 <= end1; ++c1)
                    ++column_start[static_cast<std::size_t>(c2) * across1.count + c1 + 1];
        }
        std::partial_sum(column_start.begin(), column_start.end(), column_start.begin());
        columns.entries.resize(column_start.back());
        std::vector<std::size_t> fill(column_start.begin(), column_start.end() - 1);
        for (std::size_t i = 0; i < n; ++i) {
            if (columns.oversize[i])
                continue;
            const SweepBox& box = boxes[i];
            const int end1 = across1.of(box.hi1);
            const int end2 = across2.of(box.hi2);
            for (int c2 = box.column2; c2 <= end2; ++c2)
                for (int c1 = box.column1; c1 <= end1; ++c1)
                    columns.entries[fill[static_cast<std::size_t>(c2) * across1.count + c1]++]
                        = box;
        }
    }

    // The exact test of one pair whose boxes overlap, after the adjacency and option filters.
    struct PairTest {
        const std::vector<SurfaceMesh>& surfaces;
        const std::vector<Triangle>& triangles;
        const GroundTruthOptions& options;

        void operator()(int ta, int tb, std::vector<TrianglePair>& out) const
        {
            const Triangle& a = triangles[static_cast<std::size_t>(ta)];
            const Triangle& b = triangles[static_cast<std::size_t>(tb)];
            if (a.body == b.body) {
                if (!options.self_pairs
                    || share_vertex(
                        surfaces[static_cast<std::size_t>(a.body)].faces, a.face, b.face))
                    return;
            } else if (!options.object_pairs) {
                return;
            }
            if (!triangles_intersect(corner(surfaces, a, 0), corner(surfaces, a, 1),
                    corner(surfaces, a, 2), corner(surfaces, b, 0), corner(surfaces, b, 1),
                    corner(surfaces, b, 2)))
                return;
            if (std::make_pair(b.body, b.face) < std::make_pair(a.body, a.face))
                out.push_back({ b.body, b.face, a.body, a.face });
            else
                out.push_back({ a.body, a.face, b.body, b.face });
        }
    };

    // Sweeps every column (in parallel, columns_per_task at a time: task t's pairs in found[t]),
    // testing a pair only in the column that holds the low corner of its boxes' cross-sections.
    void sweep_columns(
        Columns& columns, const PairTest& test, std::vector<std::vector<TrianglePair>>& found)
    {
        const std::size_t count = columns.count;
        const std::size_t across1 = static_cast<std::size_t>(columns.across1.count);
        const std::size_t tasks = (count + columns_per_task - 1) / columns_per_task;
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tasks, 1), [&](const auto& range) {
            for (std::size_t task = range.begin(); task < range.end(); ++task) {
                const std::size_t last = std::min(count, (task + 1) * columns_per_task);
                for (std::size_t column = task * columns_per_task; column < last; ++column) {
                    const int c1 = static_cast<int>(column % across1);
                    const int c2 = static_cast<int>(column / across1);
                    SweepBox* begin = columns.entries.data() + columns.start[column];
                    SweepBox* end = columns.entries.data() + columns.start[column + 1];
                    std::sort(begin, end, [](const SweepBox& a, const SweepBox& b) {
                        return a.lo0 < b.lo0 || (a.lo0 == b.lo0 && a.triangle < b.triangle);
                    });
                    for (const SweepBox* a = begin; a != end; ++a)
                        for (const SweepBox* b = a + 1; b != end && b->lo0 <= a->hi0; ++b)
                            if (cross_sections_overlap(*a, *b)
                                && std::max(a->column1, b->column1) == c1
                                && std::max(a->column2, b->column2) == c2)
                                test(a->triangle, b->triangle, found[task]);
                }
            }
        });
    }

    // Oversize triangles against every box that meets theirs (an oversize pair once, from the
    // lower triangle index); the k-th oversize triangle's pairs in found[first + k].
    void sweep_oversize(const std::vector<SweepBox>& boxes, const Columns& columns,
        const PairTest& test, std::size_t first, std::vector<std::vector<TrianglePair>>& found)
    {
        const std::size_t n = boxes.size();
        tbb::parallel_for(std::size_t { 0 }, columns.oversize_triangles.size(), [&](std::size_t k) {
            const SweepBox& a = boxes[columns.oversize_triangles[k]];
            for (std::size_t i = 0; i < n; ++i) {
                const SweepBox& b = boxes[i];
                if (b.triangle == a.triangle || b.lo0 > a.hi0 || b.hi0 < a.lo0
                    || !cross_sections_overlap(a, b)
                    || (columns.oversize[i] && b.triangle < a.triangle))
                    continue;
                test(a.triangle, b.triangle, found[first + k]);
            }
        });
    }

} // namespace

std::vector<TrianglePair> intersecting_triangle_pairs(
    const std::vector<SurfaceMesh>& surfaces, const GroundTruthOptions& options)
{
    validate(surfaces);
    Box3 scene;
    const std::vector<Triangle> triangles = list_triangles(surfaces, scene);
    const std::size_t n = triangles.size();
    if (n < 2)
        return {};

    // The sweep runs along the longest axis of the scene; the columns cut the other two.
    std::array<int, 3> axes = { 0, 1, 2 };
    const Vec3 sizes = scene.sizes();
    std::sort(axes.begin(), axes.end(), [&](int i, int j) { return sizes[i] > sizes[j]; });
    std::vector<SweepBox> boxes = sweep_boxes(surfaces, triangles, axes);
    const double width = column_width(boxes, sizes, axes);
    Columns columns;
    columns.across1
        = { scene.min()[axes[1]], width, static_cast<int>(column_count(sizes[axes[1]], width)) };
    columns.across2
        = { scene.min()[axes[2]], width, static_cast<int>(column_count(sizes[axes[2]], width)) };
    columns.count = static_cast<std::size_t>(columns.across1.count) * columns.across2.count;
    file_in_columns(boxes, columns);

    const PairTest test { surfaces, triangles, options };
    const std::size_t tasks = (columns.count + columns_per_task - 1) / columns_per_task;
    std::vector<std::vector<TrianglePair>> found(tasks + columns.oversize_triangles.size());
    sweep_columns(columns, test, found);
    sweep_oversize(boxes, columns, test, tasks, found);

    std::vector<TrianglePair> out;
    for (const auto& part : found)
        out.insert(out.end(), part.begin(), part.end());
    std::sort(out.begin(), out.end());
    return out;
}

} // namespace mat
