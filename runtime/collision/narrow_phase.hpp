#pragma once
// Narrow phase of the collision world (docs/method.md, section 4, step 5) over all the colliding
// medial primitive pairs of one step. Only the surface triangles and boundary nodes enclosed by a
// colliding primitive, and lying in the region of one of its pairs (the intersection of the two
// enlarged primitives' boxes, grown by the contact margin), take part:
//   - triangle pairs whose boxes overlap, decided by the exact triangle-triangle test: between
//     two bodies that have a colliding primitive pair, and within one body (self) when the two
//     triangles share no vertex and belong to a colliding self pair of primitives;
//   - each node against the triangles of the other bodies it collides with (and of its own body
//     through a colliding self pair): the closest triangle within the margin, or within what
//     the node may close in the step at its approach speed, or behind it (docs/method.md,
//     "Speculative contacts"; the search is bounded by the node's velocity relative to the
//     other body's triangles).
// Neighbouring primitives enclose many of the same triangles, so testing pair by pair repeats
// work (on the benchmark's creatures, 1795 primitive pairs gave 6372 triangle candidates for
// 2359 distinct ones, and filtering each pair's lists cost more than the tests). Instead, per
// step:
//   1. each primitive's region is the union of its pairs' regions, each pair's between two
//      bodies cut to what lies within reach of the other primitive's patch (the box of the
//      triangles and nodes that primitive encloses: a triangle meets the other's triangles only
//      there, a node finds one only within its reach); its triangles and nodes in that region are
//      marked active (a triangle enclosed by several primitives once), each with the kinds of
//      region it lies in (a pair with another body, a self pair), and it searches only those kinds;
//   2. each body's active triangles are filed in a grid of columns across one axis (the shortest
//      side of their box; cells no narrower than twice the widest triangle, by the low corner
//      of the triangle's box; a grid per size class where the sizes differ by more than 2x the
//      median, face_grid.hpp) and sorted along that axis within a column;
//   3. every active triangle (and node) looks up the boxes that overlap its own in the other
//      side's neighbouring columns (a scan from the column's start, or past a binary search in
//      a long column; with AVX-512, eight boxes per comparison), so each candidate is found and
//      tested once: within one body, a triangle looks up only the positions filed after its
//      own, and the self rows' bits are read a word at a time before the boxes. A node's search
//      reaches, in each column, only as far as the motion of that column's faces lets them take it
//      (a column holds faces close together, whose velocities differ less than the whole body's: on
//      creatures_collide this visited 4.4x fewer boxes), skips the faces further than the nearest
//      hit so far, and reads each face's corners and normal computed once per run.
// The triangle pairs found are a superset of the pair-by-pair ones (those lie in the primitives'
// regions too), so none of those is lost. Parallel (TBB) over triangles and nodes; the results
// are sorted by a total order, so they do not depend on the thread count. Buffers are members,
// reused: no allocation once warm.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/eigen_types.hpp"
#include "runtime/collision/face_grid.hpp"

namespace mat {

/// One body as the narrow phase reads it, world coordinates, for one step. Pointers, not owned.
struct NarrowPhaseBody {
    const MatX3* surface = nullptr; ///< #Vs x 3 surface vertex positions
    const MatX3i* faces = nullptr; ///< #F x 3
    const MatX3* nodes = nullptr; ///< n x 3 tet-mesh node positions
    const VecXi* face_indptr = nullptr; ///< #P + 1, CSR of the faces enclosed by each primitive
    const VecXi* face_list = nullptr;
    const VecXi* node_indptr = nullptr; ///< #P + 1, CSR of the boundary nodes of each primitive
    const VecXi* node_list = nullptr;
    bool is_static = false; ///< its nodes get no contacts
    /// How far its nodes may move in the step (m): the search for speculative contacts (run())
    /// reaches the margin plus both bodies' motion.
    double motion = 0.0;
    /// n x 3 velocities of the nodes, world coordinates (null: at rest); with nodes that are the
    /// surface vertices, of the triangles' corners too.
    const MatX3* velocities = nullptr;
    /// Per node, the faces of its own body it never pairs with (CSR, increasing; null: none).
    const VecXi* rest_near_indptr = nullptr;
    const VecXi* rest_near_list = nullptr;
    /// The "nodes" are the surface vertices (indices into `faces`): a vertex never pairs with a
    /// triangle of its own body that has it as a corner.
    bool nodes_are_vertices = false;
    /// #Vs x 3 surface vertex positions at rest: the sharp edges (edge contacts) are the rest
    /// shape's (null: the surface's at the body's first run).
    const MatX3* rest_surface = nullptr;
};

/// A colliding primitive pair as the narrow phase reads it.
struct PrimitivePairRef {
    int body_a = 0, primitive_a = 0;
    int body_b = 0, primitive_b = 0;
    Box3 region; ///< intersection of the two enlarged primitives' boxes (not grown)
};

/// The closest triangle of another body (or of a self-colliding primitive) to one node.
struct NodeCandidate {
    int body = 0; ///< the node's body
    int node = 0;
    int other_body = 0;
    int face = 0; ///< the triangle, in other_body
    double distance = 0.0; ///< signed: negative behind the triangle
    /// Signed distance from the triangle's plane along `normal`: the gap its contact starts
    /// from. The same as `distance` where the closest point is inside the triangle; nearer 0
    /// where it is on an edge or a corner (a node beside the triangle, not over it).
    double plane = 0.0;
    Vec3 closest = Vec3::Zero(); ///< closest point of the triangle
    Vec3 barycentric = Vec3::Zero(); ///< its weights on the triangle's corners
    Vec3 normal = Vec3::UnitY(); ///< the triangle's unit outward normal
};

/// The nearest sharp edge of another body (or of a self-colliding part of its own) to one sharp
/// surface edge, where the closest points of the two edges lie inside both (docs/method.md, "Edge
/// contacts"): two edges that cross between their vertices, which no vertex-face contact sees.
struct EdgeCandidate {
    int body = 0;
    int edge = 0; ///< into NarrowPhase::edges(body)
    int other_body = 0;
    int other_edge = 0;
    double s = 0.0; ///< the closest point on the edge: (1 - s) x0 + s x1
    double t = 0.0; ///< ... on the other edge: (1 - t) y0 + t y1
    /// Signed gap along `normal`: the distance when the edge is in front of the other body's
    /// surface, minus it when the two have crossed.
    double distance = 0.0;
    Vec3 normal = Vec3::UnitY(); ///< unit, outward of the other body (towards the edge)
};

/// A surface's edges: each once, its two vertices (increasing) and up to two faces; each face's
/// three edges.
struct SurfaceEdges {
    std::vector<std::array<int, 2>> vertices; ///< per edge
    std::vector<std::array<int, 2>> faces; ///< per edge, its faces (-1: none)
    std::vector<std::array<int, 3>> of_face; ///< per face, its edges (v0 v1, v1 v2, v2 v0)
};

/// The edges of a triangle mesh (#F x 3 vertex indices).
SurfaceEdges build_surface_edges(const MatX3i& faces);

/// An active face as the nodes' search reads it, once per run: its corners, unit normal (UnitY
/// if degenerate) and the fastest of its corners' velocities along that normal.
struct NarrowFace {
    Vec3 p0 = Vec3::Zero(), p1 = Vec3::Zero(), p2 = Vec3::Zero();
    Vec3 unit = Vec3::UnitY();
    bool degenerate = true;
    double normal_speed = 0.0; ///< max over the corners of unit . v (0 at rest)
};

/// (body_a, face_a, body_b, face_b) with (body_a, face_a) < (body_b, face_b).
using FacePair = std::array<int, 4>;

class NarrowPhase {
public:
    /// Runs the narrow phase on `pairs` (primitives of `bodies`) with contact margin `margin`.
    /// Speculative contacts: a node in front of a triangle is a candidate within the margin plus
    /// `extra` plus `lookahead` (s) times its approach speed (the node's velocity relative to the
    /// triangle's closest point, along the triangle's normal; the bodies' velocities). The
    /// bodies must be the same ones (same meshes) from one call to the next.
    void run(const std::vector<NarrowPhaseBody>& bodies, const std::vector<PrimitivePairRef>& pairs,
        double margin, double lookahead = 0.0, double extra = 0.0);
    /// Whether run() also finds edge-edge candidates (on bodies whose nodes are their surface
    /// vertices; off by default), and how far apart the normals of a convex edge's faces must be
    /// at rest for it to take contacts in front of another such edge (degrees; docs/method.md,
    /// "Edge contacts"). Before the first run.
    void set_edge_contacts(bool on, double sharp_degrees = default_sharp_edge_degrees)
    {
        m_edge_contacts = on;
        m_sharp_cosine = std::cos(sharp_degrees * M_PI / 180.0);
    }
    /// Whether run() tests the triangle pairs (intersecting(), triangle_tests(); on by default).
    /// They are a measurement (what --check-collisions compares, and --stats counts): no contact
    /// reads them, so a run that asks for neither skips them.
    void set_triangle_pairs(bool on) { m_triangle_pairs = on; }
    /// How fast a point closes on a point of another body along a normal in the step, at most,
    /// where either body may stop during it (docs/method.md, "Speculative contacts": a body that
    /// lands on the ground stops under one that lands on it, which at the step's start moved
    /// with it): the largest of the approach at the start velocities, the point's own (the
    /// other's body stops) and the other point's (this point's body stops); 0 if none approaches.
    /// `along`, `other_along`: their velocities along the normal, which points from the other
    /// point towards this one. `stopping` false: the approach at the start velocities only.
    static double stopping_approach(double along, double other_along, bool stopping)
    {
        return stopping ? std::max({ 0.0, other_along - along, -along, other_along })
                        : std::max(0.0, other_along - along);
    }

    /// Edges whose faces' normals are at least this far apart at rest (and convex) are sharp:
    /// only two sharp edges take a contact in front of each other. Two edges that meet flatter are
    /// held by their surfaces' vertex-face contacts (between vertices held out of the other
    /// surface, two convex edges of exterior angles a and b can cross by at most about a quarter of
    /// their length times tan(a / 2) + tan(b / 2)). On the sample creature 12% of the edges are
    /// this sharp.
    static constexpr double default_sharp_edge_degrees = 20.0;

    /// One candidate per active sharp edge of a dynamic body that has a sharp edge of a partner
    /// in front within the margin or the speculative reach, or crossed within the margin (each
    /// pair of edges found once: from the lower (body, edge) of two dynamic bodies, from the
    /// dynamic one against a static one); sorted by (body, edge).
    const std::vector<EdgeCandidate>& edge_candidates() const { return m_edge_candidates; }
    /// The edges of body b (empty unless edge contacts are on).
    const SurfaceEdges& edges(int b) const { return m_bodies[static_cast<std::size_t>(b)].edges; }
    /// Distinct edge-edge pairs tested.
    long edge_tests() const { return m_edge_tests; }

    /// The distinct intersecting triangle pairs, sorted.
    const std::vector<FacePair>& intersecting() const { return m_intersecting; }
    /// One candidate per node that has a triangle within the margin (or is behind it): the
    /// nearest (unsigned distance), ties to the lowest (body, face); sorted by (body, node).
    const std::vector<NodeCandidate>& candidates() const { return m_candidates; }
    /// Distinct triangle pairs tested (their boxes overlap).
    long triangle_tests() const { return m_triangle_tests; }
    /// Distinct node-triangle pairs tested (the node is in the triangle's box grown by the
    /// margin).
    long node_tests() const { return m_node_tests; }

    /// An active triangle or node with its box (a node: a point box).
    using Item = GridItem;

private:
    struct BodyData {
        std::vector<int> stamp; ///< #P, the run in which `region` was reset
        /// #P, union of the primitive's pairs' regions (grown): with other bodies, and within
        /// its own body (self pairs).
        std::vector<Box3> region, self_region;
        std::vector<int> active; ///< the primitives with a pair this run
        /// #P, the box of the faces and nodes a primitive encloses, at this run's positions
        /// (for the primitives in a pair: patch_stamp is the run that computed it).
        std::vector<Box3> patch;
        std::vector<int> patch_stamp;
        std::vector<int> patched; ///< the primitives whose patch this run computed
        double fastest = 0.0; ///< the speed of its fastest node, this run (with a pair)
        Box3 box; ///< of the active faces
        std::vector<int> face_stamp; ///< #F, the run in which the face was made active
        /// #F, an active face's kinds: in a region with another body (other_kind), in a self
        /// region (self_kind), or both.
        std::vector<unsigned char> face_kinds;
        std::vector<unsigned char> node_kinds; ///< per active node (`nodes`), its kinds
        VecXi face_primitive_indptr; ///< #F + 1, the primitives enclosing each face (CSR)
        VecXi face_primitives;
        VecXi node_primitive; ///< n, the primitive of each boundary node (-1: none)
        std::vector<Item> nodes; ///< active
        /// The active faces by their boxes (its items are the active faces, in filed order).
        FaceGrid grid;
        /// The motion of a face's corners: the fastest corner's speed, their mean velocity and
        /// how far a corner's velocity is from it at most.
        struct FaceMotion {
            double speed = 0.0;
            Vec3 mean = Vec3::Zero();
            double spread = 0.0;
        };
        /// Per position in `grid`.
        std::vector<FaceMotion> motion;
        /// Per position in `grid`.
        std::vector<NarrowFace> geometry;

        /// Per column of `grid`: the box of its faces and their motion (FaceMotion of all its
        /// faces together: the fastest corner, the mean of the faces' means, and how far a
        /// corner's velocity is from it at most), so that a node's search grows by the reach of
        /// each column's own motion rather than the whole body's.
        struct ColumnMotion {
            Box3 box;
            FaceMotion motion;
        };
        std::vector<ColumnMotion> columns;
        /// The mean of the active faces' mean velocities, and the most a velocity of a point of
        /// an active face differs from it (via its face's mean: |mean_k - this| + spread_k).
        Vec3 mean_velocity = Vec3::Zero();
        double velocity_spread = 0.0;
        std::vector<int> partners; ///< bodies with a colliding pair, increasing (may hold itself)
        std::vector<int> partner_stamp; ///< per body, the run in which it became a partner
        SurfaceEdges edges; ///< with edge contacts
        std::vector<int> sharp_edges; ///< the edges sharp at rest, increasing
        /// An active edge as the edges' search reads it, once per run: its ends, their
        /// velocities (mean, spread about it, the faster one's speed), box, and outward
        /// direction (the sum of its faces' unit normals).
        struct ActiveEdge {
            int edge = 0;
            Vec3 x0 = Vec3::Zero(), x1 = Vec3::Zero();
            Vec3 v0 = Vec3::Zero(), v1 = Vec3::Zero();
            FaceMotion motion; ///< of its two ends
            Box3 box;
            Vec3 outward = Vec3::Zero();
        };
        /// The active sharp edges (an active face's that are sharp at rest: only such edges take
        /// contacts in front of each other; docs/method.md, "Edge contacts"), and a grid of
        /// their boxes (its items' indices are into active_edges).
        std::vector<ActiveEdge> active_edges;
        FaceGrid edge_grid;
        /// Per column of edge_grid: its edges' box and motion (as `columns` for the faces).
        std::vector<ColumnMotion> edge_columns;
        std::vector<std::uint64_t> self_pairs; ///< (low primitive << 32) | high, sorted
        /// With self pairs, which active faces each primitive may pair with, as bits, so that a
        /// search within one body drops its own neighbourhood at one load per face (the same
        /// answer as self_pair_allowed): per primitive with a self pair, a row of one bit per
        /// position in `grid`, set for the faces of the primitives it collides with.
        std::vector<int> face_position; ///< #F, the face's position in `grid` (active faces)
        std::vector<int> self_row; ///< #P, the primitive's row (-1: none)
        std::vector<int> self_rowed; ///< the primitives with a row this run
        /// Per row, its partner primitives (CSR, row_partner_start has rows + 1 entries).
        std::vector<int> row_partner_start, row_partners;
        std::vector<int> row_fill; ///< workspace of the CSR
        /// Per row, its primitive's active faces as (word index, bits) over the grid positions:
        /// row_word_count[r] words from row_word_start[r].
        std::vector<int> row_word_start, row_word_count;
        std::vector<std::uint32_t> row_word_index;
        std::vector<std::uint64_t> row_word_bits;
        std::vector<std::uint64_t> self_bits; ///< rows x self_words (empty: too large, none)
        std::size_t self_words = 0;
    };
    struct Scratch {
        std::vector<FacePair> intersecting;
        long triangle_tests = 0;
        long node_tests = 0;
        long edge_tests = 0;
    };

    void prepare(const std::vector<NarrowPhaseBody>& bodies);
    void activate(const std::vector<NarrowPhaseBody>& bodies,
        const std::vector<PrimitivePairRef>& pairs, double margin, double lookahead, double extra);
    /// work(body, data) for every body, in parallel.
    template <class Work>
    void for_each_body(const std::vector<NarrowPhaseBody>& bodies, const Work& work);
    /// The patches of the primitives in `pairs` between two bodies (BodyData::patch).
    void compute_patches(
        const std::vector<NarrowPhaseBody>& bodies, const std::vector<PrimitivePairRef>& pairs);
    /// Grows the regions of a pair's two primitives by its region (between two bodies, each
    /// within the reach of the other's patch), and records the partners (not if neither is
    /// within reach).
    void add_pair(const std::vector<NarrowPhaseBody>& bodies, const PrimitivePairRef& pair,
        double margin, double lookahead, double extra);
    /// The kinds of region an active face or node lies in (BodyData::face_kinds).
    static constexpr unsigned char other_kind = 1, self_kind = 2;
    /// Extends a primitive's region (or, `self`, its self region) by `region` (resetting both on
    /// its first pair of the run).
    void extend_region(int body, int primitive, const Box3& region, bool self);
    /// Files a body's triangles and nodes that lie in the regions of its active primitives.
    void collect_active(const NarrowPhaseBody& body, BodyData& data) const;
    /// m_axis: the shortest side of the box of every body's active triangles.
    void choose_sweep_axis();
    /// Files a body's active triangles in its grid along `axis`, with their corners' motion.
    static void file_faces(const NarrowPhaseBody& body, BodyData& data, int axis);
    /// Per column of `grid`: the box of its items and their motion together (the fastest, the
    /// mean of their means, and how far a velocity is from it at most), with motion_at(k) the
    /// motion of the item at position k.
    template <class MotionAt>
    static void summarize_columns(const FaceGrid& grid, const MotionAt& motion_at,
        std::vector<BodyData::ColumnMotion>& columns);
    bool self_pair_allowed(int body, int face_a, int face_b, bool node_a) const;
    /// The plane and the corners' motion of the face at grid position k (file_faces).
    static void place_face(const NarrowPhaseBody& body, BodyData& data, std::size_t k);
    /// A body's self rows (BodyData::self_bits), after file_faces.
    void mark_self_rows(const NarrowPhaseBody& body, BodyData& data) const;
    /// Row r's primitive's active faces as words of bits (mark_self_rows).
    void primitive_words(const NarrowPhaseBody& body, BodyData& data, std::size_t r) const;
    /// Word w of the grid positions that face `face` of a body may pair with within it: the
    /// union of its primitives' self rows (self_pair_allowed through the rows).
    static std::uint64_t face_row_word(const BodyData& data, int face, int w)
    {
        std::uint64_t word = 0;
        const VecXi& indptr = data.face_primitive_indptr;
        for (int i = indptr(face); i < indptr(face + 1); ++i) {
            const int row = data.self_row[static_cast<std::size_t>(data.face_primitives(i))];
            if (row >= 0)
                word |= data.self_bits[static_cast<std::size_t>(row) * data.self_words
                    + static_cast<std::size_t>(w)];
        }
        return word;
    }
    /// visit(scratch, k) for k in [0, n): fixed chunks in parallel, each with its own scratch.
    template <class Visit> void in_chunks(std::size_t n, const Visit& visit);
    /// Empties every chunk's scratch.
    void clear_scratch();
    /// m_work and m_node_work: every body's active triangles and nodes.
    void build_work_lists();
    /// Tests triangle m_work[k] against the overlapping triangles of its partners.
    void test_triangle(
        const std::vector<NarrowPhaseBody>& bodies, Scratch& scratch, std::size_t k) const;
    /// The nearest triangle to node m_node_work[k] in `best`; false if none qualifies.
    bool nearest_triangle(const std::vector<NarrowPhaseBody>& bodies, double margin,
        double lookahead, double extra, Scratch& scratch, std::size_t k, NodeCandidate& best) const;
    /// Whether node `node` of body `body` never pairs with its own face `face`.
    /// `allowed_known`: its primitives are known to pair (the self rows), not searched again.
    bool own_face_excluded(
        const NarrowPhaseBody& own, int body, int node, int face, bool allowed_known) const;
    /// m_edge_work: each active sharp edge of a dynamic body.
    void build_edge_work(const std::vector<NarrowPhaseBody>& bodies);
    /// A body's BodyData::active_edges (after file_faces).
    void collect_active_edges(const NarrowPhaseBody& body, BodyData& data, int axis) const;
    /// A body's SurfaceEdges and its edges sharp at rest (first run).
    void find_sharp_edges(const NarrowPhaseBody& body, BodyData& data) const;

    /// The nearest edge to edge m_edge_work[k] in `best`; false if none qualifies.
    bool nearest_edge(const std::vector<NarrowPhaseBody>& bodies, double margin, double lookahead,
        double extra, Scratch& scratch, std::size_t k, EdgeCandidate& best) const;
    /// Whether edges ea and eb of one body never pair: they share a vertex, or a vertex of one is
    /// near a face of the other at rest, or no colliding self pair holds their faces.
    bool own_edge_excluded(const NarrowPhaseBody& own, int body, int ea, int eb) const;
    /// Gathers the chunks' results into m_intersecting and m_candidates, sorted.
    void merge_results();

    int m_run = 0;
    Index m_axis = 0; ///< the sweep axis of this run
    std::vector<BodyData> m_bodies;
    std::vector<std::array<int, 2>> m_work; ///< (body, index into its active faces)
    std::vector<std::array<int, 2>> m_node_work; ///< (body, index into its active nodes)
    std::vector<std::array<int, 2>> m_edge_work; ///< (body, index into its active_edges)
    std::vector<EdgeCandidate> m_edge_best; ///< per m_edge_work
    std::vector<char> m_edge_found;
    std::vector<EdgeCandidate> m_edge_candidates;
    long m_edge_tests = 0;
    bool m_edge_contacts = false;
    bool m_triangle_pairs = true;
    double m_sharp_cosine = 0.0; ///< cos of the sharp edges' least angle
    std::vector<NodeCandidate> m_node_best; ///< per m_node_work
    std::vector<char> m_node_found;
    /// One per chunk of the work lists (a fixed number, never per thread): each chunk's results
    /// do not depend on the thread split, so once warm a repeated scene allocates nothing.
    std::vector<Scratch> m_scratch;
    std::vector<FacePair> m_intersecting;
    std::vector<NodeCandidate> m_candidates;
    long m_triangle_tests = 0;
    long m_node_tests = 0;
};

template <class MotionAt>
void NarrowPhase::summarize_columns(
    const FaceGrid& grid, const MotionAt& motion_at, std::vector<BodyData::ColumnMotion>& columns)
{
    // In parallel over the columns, each written by one task.
    columns.resize(static_cast<std::size_t>(grid.num_columns()));
    tbb::parallel_for(tbb::blocked_range<int>(0, grid.num_columns(), 64),
        [&](const tbb::blocked_range<int>& range) {
            for (int c = range.begin(); c != range.end(); ++c) {
                BodyData::ColumnMotion& column = columns[static_cast<std::size_t>(c)];
                const std::size_t begin = static_cast<std::size_t>(grid.column_begin(c));
                const std::size_t end = static_cast<std::size_t>(grid.column_begin(c + 1));
                column = BodyData::ColumnMotion {};
                if (begin == end)
                    continue;
                for (std::size_t k = begin; k < end; ++k) {
                    column.box.extend(grid.at(k).box);
                    column.motion.speed = std::max(column.motion.speed, motion_at(k).speed);
                    column.motion.mean += motion_at(k).mean;
                }
                column.motion.mean /= static_cast<double>(end - begin);
                for (std::size_t k = begin; k < end; ++k)
                    column.motion.spread = std::max(column.motion.spread,
                        (motion_at(k).mean - column.motion.mean).norm() + motion_at(k).spread);
            }
        });
}

} // namespace mat
