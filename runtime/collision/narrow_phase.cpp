#include "runtime/collision/narrow_phase.hpp"

#include <cmath>

#include "runtime/collision/triangle_tests.hpp"

namespace mat {

namespace {

    bool boxes_overlap(const Box3& a, const Box3& b)
    {
        return (a.min().x() <= b.max().x()) & (a.min().y() <= b.max().y())
            & (a.min().z() <= b.max().z()) & (b.min().x() <= a.max().x())
            & (b.min().y() <= a.max().y()) & (b.min().z() <= a.max().z());
    }

    /// Whether p lies in `box` grown by `grow` on every side.
    bool contains_grown(const Box3& box, const Vec3& p, double grow)
    {
        return (p.x() >= box.min().x() - grow) & (p.x() <= box.max().x() + grow)
            & (p.y() >= box.min().y() - grow) & (p.y() <= box.max().y() + grow)
            & (p.z() >= box.min().z() - grow) & (p.z() <= box.max().z() + grow);
    }

    /// The faces of primitive p whose boxes meet `region`, in CSR order.
    void faces_in_region(
        const NarrowPhaseBody& body, int p, const Box3& region, std::vector<int>& out)
    {
        out.clear();
        const VecXi& indptr = *body.face_indptr;
        const VecXi& list = *body.face_list;
        const std::vector<Box3>& boxes = *body.face_boxes;
        for (int j = indptr(p); j < indptr(p + 1); ++j) {
            const int f = list(j);
            if (boxes_overlap(boxes[static_cast<std::size_t>(f)], region))
                out.push_back(f);
        }
    }

    Vec3 corner(const NarrowPhaseBody& body, int f, int c)
    {
        return body.surface->row((*body.faces)(f, c)).transpose();
    }

    /// Nodes of primitive `prim_a` of `a` inside `region` against the triangles `faces_b` of `b`:
    /// per node, the triangle with the smallest unsigned distance (the first in list order on a
    /// tie) among those within the margin or behind.
    void nodes_against(const NarrowPhaseBody& a, int body_a, int prim_a, const NarrowPhaseBody& b,
        int body_b, const std::vector<int>& faces_b, const Box3& region, double margin, int pair,
        NarrowPhaseScratch& scratch)
    {
        if (a.is_static || faces_b.empty())
            return;
        const VecXi& indptr = *a.node_indptr;
        const std::vector<Box3>& boxes = *b.face_boxes;
        for (int k = indptr(prim_a); k < indptr(prim_a + 1); ++k) {
            const int node = (*a.node_list)(k);
            const Vec3 x = a.nodes->row(node).transpose();
            if (!contains_grown(region, x, 0.0))
                continue;
            NodeCandidate best;
            bool found = false;
            for (const int f : faces_b) {
                if (!contains_grown(boxes[static_cast<std::size_t>(f)], x, margin))
                    continue;
                const PointTriangleClosest closest
                    = point_triangle_closest(x, corner(b, f, 0), corner(b, f, 1), corner(b, f, 2));
                const Vec3 n = b.face_normals->row(f).transpose();
                const double distance = std::sqrt(closest.squared_distance);
                const double signed_distance
                    = n.dot(x - closest.point) < 0.0 ? -distance : distance;
                if (signed_distance >= margin)
                    continue;
                if (!found || std::abs(signed_distance) < std::abs(best.distance)) {
                    best.distance = signed_distance;
                    best.closest = closest.point;
                    best.normal = n;
                    found = true;
                }
            }
            if (found) {
                best.body = body_a;
                best.node = node;
                best.pair = pair;
                best.other_body = body_b;
                scratch.candidates.push_back(best);
            }
        }
    }

} // namespace

void narrow_phase_pair(const NarrowPhaseBody& a, int body_a, int prim_a, const NarrowPhaseBody& b,
    int body_b, int prim_b, const Box3& region, double margin, int pair,
    NarrowPhaseScratch& scratch)
{
    const Box3 grown(region.min().array() - margin, region.max().array() + margin);
    if (grown.isEmpty())
        return;
    faces_in_region(a, prim_a, grown, scratch.faces_a);
    faces_in_region(b, prim_b, grown, scratch.faces_b);
    const std::vector<Box3>& boxes_a = *a.face_boxes;
    const std::vector<Box3>& boxes_b = *b.face_boxes;
    const MatX3i& faces_a = *a.faces;
    const MatX3i& faces_b = *b.faces;
    const bool same_body = body_a == body_b;

    // Triangle-triangle tests among the triangles in the region (box-filtered).
    for (const int fa : scratch.faces_a) {
        const Box3& box_a = boxes_a[static_cast<std::size_t>(fa)];
        for (const int fb : scratch.faces_b) {
            if (same_body) {
                bool shared = fa == fb;
                for (int u = 0; u < 3; ++u)
                    for (int v = 0; v < 3; ++v)
                        shared |= faces_a(fa, u) == faces_b(fb, v);
                if (shared)
                    continue;
            }
            if (!boxes_overlap(box_a, boxes_b[static_cast<std::size_t>(fb)]))
                continue;
            ++scratch.triangle_tests;
            if (triangles_intersect(corner(a, fa, 0), corner(a, fa, 1), corner(a, fa, 2),
                    corner(b, fb, 0), corner(b, fb, 1), corner(b, fb, 2))) {
                const bool a_first = body_a < body_b || (body_a == body_b && fa < fb);
                scratch.intersecting.push_back(a_first ? FacePair { body_a, fa, body_b, fb }
                                                       : FacePair { body_b, fb, body_a, fa });
            }
        }
    }

    // Nodes of each primitive against the triangles of the other.
    nodes_against(a, body_a, prim_a, b, body_b, scratch.faces_b, grown, margin, pair, scratch);
    nodes_against(b, body_b, prim_b, a, body_a, scratch.faces_a, grown, margin, pair, scratch);
}

} // namespace mat
