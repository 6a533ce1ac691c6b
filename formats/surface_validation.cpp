#include "formats/surface_validation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>
#include <vector>

#include <fmt/format.h>

#include "common/error.hpp"
#include "common/union_find.hpp"

namespace mat {

namespace {

    /// One report line per class: its name in errors, its element nouns, whether it blocks.
    struct IssueClass {
        const char* name;
        const char* one;
        const char* many;
        bool blocking;
        SurfaceIssue SurfaceReport::*member;
    };

    const std::array<IssueClass, 10> k_classes { {
        { "invalid indices", "face with an index out of range", "faces with an index out of range",
            true, &SurfaceReport::invalid_indices },
        { "non-finite coordinates", "vertex with NaN or Inf coordinates",
            "vertices with NaN or Inf coordinates", true, &SurfaceReport::non_finite },
        { "not closed", "boundary edge", "boundary edges", true, &SurfaceReport::boundary_edges },
        { "non-manifold edges", "edge with more than two faces", "edges with more than two faces",
            true, &SurfaceReport::non_manifold_edges },
        { "non-manifold vertices", "vertex whose faces form several fans",
            "vertices whose faces form several fans", true, &SurfaceReport::non_manifold_vertices },
        { "inconsistent orientation", "edge used twice in the same direction",
            "edges used twice in the same direction", true,
            &SurfaceReport::inconsistent_orientation },
        { "inward orientation", "closed component facing inward", "closed components facing inward",
            true, &SurfaceReport::inward_orientation },
        { "degenerate faces", "face with zero area or a repeated vertex",
            "faces with zero area or a repeated vertex", true, &SurfaceReport::degenerate_faces },
        { "several components", "component", "components", false, &SurfaceReport::components },
        { "unreferenced vertices", "vertex used by no face", "vertices used by no face", false,
            &SurfaceReport::unreferenced_vertices },
    } };

    constexpr double k_pi = 3.14159265358979323846;

    std::string counted(const IssueClass& c, Index count)
    {
        return fmt::format("{} {}", count, count == 1 ? c.one : c.many);
    }

    /// Records one more occurrence; the first one becomes the example.
    template <typename Describe> void note(SurfaceIssue& issue, Index element, Describe&& describe)
    {
        if (issue.count++ == 0) {
            issue.example = element;
            issue.description = describe();
        }
    }

    /// A face's directed edge faces(f, k) -> faces(f, k + 1), keyed by its undirected vertices.
    struct HalfEdge {
        int lo, hi;
        int face;
        int corner; ///< k
        bool operator<(const HalfEdge& o) const
        {
            return std::tie(lo, hi, face, corner) < std::tie(o.lo, o.hi, o.face, o.corner);
        }
    };

    // Solid angle of triangle (a, b, c) seen from the origin: Van Oosterom & Strackee 1983,
    // tan(Omega / 2) = a.(b x c) / (|a||b||c| + (a.b)|c| + (b.c)|a| + (c.a)|b|).
    double solid_angle(const Vec3& a, const Vec3& b, const Vec3& c)
    {
        const double la = a.norm(), lb = b.norm(), lc = c.norm();
        const double numerator = a.dot(b.cross(c));
        const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        return 2.0 * std::atan2(numerator, denominator);
    }

    std::string format_point(const Eigen::Ref<const Vec3>& p)
    {
        return fmt::format("({:.6g}, {:.6g}, {:.6g})", p.x(), p.y(), p.z());
    }

    // Notes the non-finite vertices and extends the bbox over the others; returns the flags.
    std::vector<char> check_coordinates(const SurfaceMesh& mesh, SurfaceReport& report)
    {
        const Index nv = mesh.num_vertices();
        const auto& P = mesh.positions;
        std::vector<char> finite(nv, 1);
        for (Index v = 0; v < nv; ++v) {
            if (P.row(v).allFinite()) {
                report.bbox.extend(Vec3(P.row(v).transpose()));
                continue;
            }
            finite[v] = 0;
            note(report.non_finite, v, [&] {
                return fmt::format("vertex {} is {}", v, format_point(P.row(v).transpose()));
            });
        }
        return finite;
    }

    /// Which faces enter the topology (three distinct valid indices) and which the geometry
    /// (also finite corners).
    struct FaceFlags {
        std::vector<char> topological, geometric;
    };

    // Faces: index range, repeated indices, area, and the signed volume about `origin`; then the
    // vertices no face references.
    FaceFlags check_faces(const SurfaceMesh& mesh, const std::vector<char>& finite,
        double area_tolerance, const Vec3& origin, SurfaceReport& report)
    {
        const Index nv = mesh.num_vertices();
        const Index nf = mesh.num_faces();
        const auto& P = mesh.positions;
        const auto& F = mesh.faces;
        FaceFlags flags { std::vector<char>(nf, 0), std::vector<char>(nf, 0) };
        std::vector<char> referenced(nv, 0);
        for (Index f = 0; f < nf; ++f) {
            const int a = F(f, 0), b = F(f, 1), c = F(f, 2);
            const auto in_range = [nv](int i) { return i >= 0 && i < nv; };
            if (!in_range(a) || !in_range(b) || !in_range(c)) {
                note(report.invalid_indices, f, [&] {
                    return fmt::format(
                        "face {} is ({}, {}, {}) but there are {} vertices", f, a, b, c, nv);
                });
                continue;
            }
            referenced[a] = referenced[b] = referenced[c] = 1;
            if (a == b || b == c || c == a) {
                note(report.degenerate_faces, f, [&] {
                    return fmt::format("face {} ({}, {}, {}) repeats a vertex", f, a, b, c);
                });
                continue;
            }
            flags.topological[f] = 1;
            if (!finite[a] || !finite[b] || !finite[c])
                continue;
            flags.geometric[f] = 1;
            const Vec3 pa = P.row(a), pb = P.row(b), pc = P.row(c);
            const double area = 0.5 * (pb - pa).cross(pc - pa).norm();
            if (area <= area_tolerance)
                note(report.degenerate_faces, f, [&] {
                    return fmt::format("face {} ({}, {}, {}) has area {:.3g} (tolerance {:.3g})", f,
                        a, b, c, area, area_tolerance);
                });
            // Signed volume: divergence theorem, sum of (1/6) (a - o) . ((b - o) x (c - o)).
            report.signed_volume += (pa - origin).dot((pb - origin).cross(pc - origin)) / 6.0;
        }
        for (Index v = 0; v < nv; ++v)
            if (!referenced[v])
                note(report.unreferenced_vertices, v, [&] {
                    return fmt::format("vertex {} at {}", v, format_point(P.row(v).transpose()));
                });
        return flags;
    }

    /// The edges' connectivity: corner 3f + k sits at vertex F(f, k); corners joined across an
    /// edge share a set, so do faces sharing an edge.
    struct EdgeConnectivity {
        UnionFind corners;
        UnionFind face_sets;
        std::vector<char> open_face; ///< on a boundary, non-manifold or inconsistent edge
    };

    // Edges: sorts the half-edges by undirected key; each run is one edge and its faces. Notes
    // boundary, non-manifold and inconsistently oriented edges and joins corners and faces.
    EdgeConnectivity check_edges(
        const SurfaceMesh& mesh, const std::vector<char>& topological, SurfaceReport& report)
    {
        const Index nf = mesh.num_faces();
        const auto& F = mesh.faces;
        std::vector<HalfEdge> half_edges;
        half_edges.reserve(3 * nf);
        for (Index f = 0; f < nf; ++f)
            if (topological[f])
                for (int k = 0; k < 3; ++k) {
                    const int a = F(f, k), b = F(f, (k + 1) % 3);
                    half_edges.push_back({ std::min(a, b), std::max(a, b), int(f), k });
                }
        std::sort(half_edges.begin(), half_edges.end());

        EdgeConnectivity edges { UnionFind(3 * nf), UnionFind(nf), std::vector<char>(nf, 0) };
        std::vector<char>& open_face = edges.open_face;
        const auto corner_at = [&](const HalfEdge& h, int vertex) {
            return 3 * Index(h.face)
                + (F(h.face, h.corner) == vertex ? h.corner : (h.corner + 1) % 3);
        };
        for (std::size_t begin = 0; begin < half_edges.size();) {
            std::size_t end = begin + 1;
            while (end < half_edges.size() && half_edges[end].lo == half_edges[begin].lo
                && half_edges[end].hi == half_edges[begin].hi)
                ++end;
            const HalfEdge& h = half_edges[begin];
            const std::size_t n = end - begin;
            const int a = F(h.face, h.corner), b = F(h.face, (h.corner + 1) % 3);
            if (n == 1) {
                open_face[h.face] = 1;
                note(report.boundary_edges, h.face,
                    [&] { return fmt::format("edge ({}, {}) of face {}", a, b, h.face); });
            } else if (n > 2) {
                for (std::size_t i = begin; i < end; ++i)
                    open_face[half_edges[i].face] = 1;
                note(report.non_manifold_edges, h.face, [&] {
                    return fmt::format("edge ({}, {}) shared by {} faces: {}, {}, {}{}", h.lo, h.hi,
                        n, half_edges[begin].face, half_edges[begin + 1].face,
                        half_edges[begin + 2].face, n > 3 ? ", ..." : "");
                });
            } else {
                const HalfEdge& g = half_edges[begin + 1];
                if (F(g.face, g.corner) == a) {
                    open_face[h.face] = open_face[g.face] = 1;
                    note(report.inconsistent_orientation, h.face, [&] {
                        return fmt::format(
                            "edge ({}, {}) used in the same direction by faces {} and {}", a, b,
                            h.face, g.face);
                    });
                }
            }
            for (std::size_t i = begin + 1; i < end; ++i) {
                edges.corners.unite(corner_at(h, h.lo), corner_at(half_edges[i], h.lo));
                edges.corners.unite(corner_at(h, h.hi), corner_at(half_edges[i], h.hi));
                edges.face_sets.unite(h.face, half_edges[i].face);
            }
            begin = end;
        }
        return edges;
    }

    // Vertices: the corners around a vertex joined through shared edges form its fans; notes
    // the vertices with several.
    void check_vertex_fans(const SurfaceMesh& mesh, const std::vector<char>& topological,
        UnionFind& corners, SurfaceReport& report)
    {
        const Index nf = mesh.num_faces();
        const auto& F = mesh.faces;
        std::vector<std::pair<int, Index>> fans; // (vertex, fan root)
        fans.reserve(3 * nf);
        for (Index f = 0; f < nf; ++f)
            if (topological[f])
                for (int k = 0; k < 3; ++k)
                    fans.emplace_back(F(f, k), corners.find(3 * f + k));
        std::sort(fans.begin(), fans.end());
        fans.erase(std::unique(fans.begin(), fans.end()), fans.end());
        for (std::size_t begin = 0; begin < fans.size();) {
            std::size_t end = begin + 1;
            while (end < fans.size() && fans[end].first == fans[begin].first)
                ++end;
            if (end - begin > 1) {
                const int v = fans[begin].first;
                note(report.non_manifold_vertices, v, [&] {
                    return fmt::format("vertex {} has {} separate fans of faces, e.g. around "
                                       "faces {} and {}",
                        v, end - begin, fans[begin].second / 3, fans[begin + 1].second / 3);
                });
            }
            begin = end;
        }
    }

    /// Faces connected through edges, numbered by their first face; per component its size,
    /// whether it is closed, its signed volume and its bbox.
    struct Components {
        std::vector<Index> component; ///< per face, -1 if not topological
        std::vector<Index> first_face, size;
        std::vector<char> closed;
        std::vector<double> volume;
        std::vector<Box3> box;
    };

    // Numbers the components and measures each (volume about `origin`); reports several.
    Components find_components(const SurfaceMesh& mesh, const FaceFlags& flags,
        EdgeConnectivity& edges, const Vec3& origin, SurfaceReport& report)
    {
        const Index nf = mesh.num_faces();
        const auto& P = mesh.positions;
        const auto& F = mesh.faces;
        Components components;
        components.component.assign(nf, -1);
        std::vector<Index>& component = components.component;
        std::vector<Index>& first_face = components.first_face;
        std::vector<Index>& size = components.size;
        std::vector<char>& closed = components.closed;
        std::vector<double>& volume = components.volume;
        std::vector<Box3>& box = components.box;
        for (Index f = 0; f < nf; ++f) {
            if (!flags.topological[f])
                continue;
            const Index root = edges.face_sets.find(f);
            if (component[root] < 0) {
                component[root] = static_cast<Index>(first_face.size());
                first_face.push_back(f);
                size.push_back(0);
                closed.push_back(1);
                volume.push_back(0.0);
                box.emplace_back();
            }
            const Index c = component[f] = component[root];
            ++size[c];
            if (edges.open_face[f] || !flags.geometric[f]) {
                closed[c] = 0;
                continue;
            }
            const Vec3 pa = P.row(F(f, 0)), pb = P.row(F(f, 1)), pc = P.row(F(f, 2));
            volume[c] += (pa - origin).dot((pb - origin).cross(pc - origin)) / 6.0;
            box[c].extend(pa).extend(pb).extend(pc);
        }
        const Index nc = static_cast<Index>(first_face.size());
        report.num_components = nc;
        if (nc > 1) {
            report.components.count = nc;
            report.components.example = 1;
            report.components.description = fmt::format(
                "component 1 with {} faces, starting at face {}", size[1], first_face[1]);
        }
        return components;
    }

    // Orientation of closed components: outer shells must enclose positive volume, cavities
    // (inside an odd number of other closed components) negative. Nesting is tested with the
    // generalized winding number (Jacobson et al. 2013) of each candidate container at a point
    // of the component; only containers whose bounding box holds the component are tried.
    void check_orientation(
        const SurfaceMesh& mesh, const Components& components, SurfaceReport& report)
    {
        const Index nf = mesh.num_faces();
        const Index nc = static_cast<Index>(components.first_face.size());
        const auto& P = mesh.positions;
        const auto& F = mesh.faces;
        const std::vector<Index>& component = components.component;
        const std::vector<char>& closed = components.closed;
        std::vector<std::vector<Index>> component_faces;
        std::vector<Index> closed_ids;
        for (Index c = 0; c < nc; ++c)
            if (closed[c])
                closed_ids.push_back(c);
        std::vector<Index> depth(nc, 0);
        if (closed_ids.size() > 1) {
            component_faces.resize(nc);
            for (Index f = 0; f < nf; ++f)
                if (component[f] >= 0 && closed[component[f]])
                    component_faces[component[f]].push_back(f);
            for (Index c : closed_ids) {
                const Index f0 = components.first_face[c];
                const Vec3 point
                    = (P.row(F(f0, 0)) + P.row(F(f0, 1)) + P.row(F(f0, 2))).transpose() / 3.0;
                for (Index d : closed_ids) {
                    if (d == c || !components.box[d].contains(components.box[c]))
                        continue;
                    double omega = 0.0;
                    for (Index f : component_faces[d])
                        omega += solid_angle(P.row(F(f, 0)).transpose() - point,
                            P.row(F(f, 1)).transpose() - point, P.row(F(f, 2)).transpose() - point);
                    if (std::abs(omega) > 2.0 * k_pi)
                        ++depth[c];
                }
            }
        }
        for (Index c : closed_ids) {
            const bool cavity = depth[c] % 2 == 1;
            const double volume = components.volume[c];
            if (cavity ? volume > 0.0 : volume < 0.0)
                note(report.inward_orientation, c, [&] {
                    return fmt::format("component {} ({} faces, starting at face {}{}) has signed "
                                       "volume {:.6g}",
                        c, components.size[c], components.first_face[c],
                        cavity ? fmt::format(", a cavity inside {} others", depth[c]) : "", volume);
                });
        }
    }

} // namespace

SurfaceReport validate_surface(const SurfaceMesh& mesh, double relative_area_tolerance)
{
    SurfaceReport report;
    report.num_vertices = mesh.num_vertices();
    report.num_faces = mesh.num_faces();

    const std::vector<char> finite = check_coordinates(mesh, report);
    const double diagonal = report.bbox.isEmpty() ? 0.0 : report.bbox.diagonal().norm();
    const double area_tolerance = relative_area_tolerance * diagonal * diagonal;
    const Vec3 origin = report.bbox.isEmpty() ? Vec3(Vec3::Zero()) : Vec3(report.bbox.center());

    // Only faces with three distinct valid indices enter the topology; only those with finite
    // corners enter areas and volumes.
    const FaceFlags flags = check_faces(mesh, finite, area_tolerance, origin, report);
    EdgeConnectivity edges = check_edges(mesh, flags.topological, report);
    check_vertex_fans(mesh, flags.topological, edges.corners, report);
    const Components components = find_components(mesh, flags, edges, origin, report);
    check_orientation(mesh, components, report);
    return report;
}

bool SurfaceReport::is_closed_manifold() const
{
    if (num_faces == 0)
        return false;
    for (const IssueClass& c : k_classes)
        if (c.blocking && (this->*c.member).count > 0)
            return false;
    return true;
}

std::string SurfaceReport::summary(const std::string& file) const
{
    std::string out = fmt::format("{}: {} vertices, {} faces, {} connected component{}\n", file,
        num_vertices, num_faces, num_components, num_components == 1 ? "" : "s");
    if (bbox.isEmpty())
        out += "  bounding box: empty\n";
    else
        out += fmt::format("  bounding box: {} to {}, diagonal {:.6g}\n", format_point(bbox.min()),
            format_point(bbox.max()), bbox.diagonal().norm());
    out += fmt::format("  signed volume: {:.6g}{}\n", signed_volume,
        boundary_edges || non_manifold_edges ? " (not meaningful: the surface is not closed)" : "");
    const IssueClass* first_blocking = nullptr;
    for (const IssueClass& c : k_classes) {
        const SurfaceIssue& issue = this->*c.member;
        if (c.member == &SurfaceReport::components)
            continue; // already on the first line
        if (c.blocking && issue.count > 0 && !first_blocking)
            first_blocking = &c;
        out += fmt::format("  {}{}: {}{}\n", !c.blocking && issue.count > 0 ? "(warning) " : "",
            c.many, issue.count, issue.count > 0 ? ", e.g. " + issue.description : std::string());
    }
    if (self_intersections_tested)
        out += fmt::format("  intersecting face pairs: {}{}\n", self_intersections.count,
            self_intersections ? ", e.g. " + self_intersections.description : std::string());
    if (num_faces == 0)
        out += "  verdict: not usable as a solid: no faces";
    else if (first_blocking)
        out += fmt::format("  verdict: not usable as a solid: {}", first_blocking->name);
    else if (self_intersections)
        out += "  verdict: closed, manifold and outward-oriented, but intersects itself";
    else
        out += "  verdict: closed, manifold and outward-oriented";
    return out;
}

void require_closed_manifold(const SurfaceReport& report, const std::string& file)
{
    if (report.num_faces == 0)
        throw_error("{}: empty surface: no faces", file);
    for (const IssueClass& c : k_classes) {
        const SurfaceIssue& issue = report.*c.member;
        if (c.blocking && issue.count > 0)
            throw_error(
                "{}: {}: {}, e.g. {}", file, c.name, counted(c, issue.count), issue.description);
    }
}

} // namespace mat
