#pragma once
// Collision between bodies and within a body, once per time step (docs/method.md, section 4):
//   1. bounds: each body's medial primitives follow the deformation and are enlarged so that
//      they still enclose the surface vertices (MedialBounds): by default the exact per-vertex
//      increments from the node positions, which every solver has each step (on the benchmark's
//      creatures in contact, the handle bound from q gives increments of 8% of the body's
//      diagonal on average, the exact ones under 0.01%, and 15 times the primitive pairs; the
//      exact update is also the cheaper one); the lazy update and, for tests and benchmarks
//      only, the handle bound from q (CollisionVariants::bounds_from_positions = false) are
//      kept for comparison; then the primitives are placed in the world;
//      a body that has not moved since the last step (a sleeping or static body,
//      CollisionBodyState::reuse_bounds) keeps its bounds, surface and boxes: nothing is
//      recomputed for it;
//   2. object level: each body's box (its primitives' boxes, so grown by the margin) against
//      the others'; only pairs of bodies whose boxes meet and of which one is dynamic go on,
//      and only the bodies in such a pair (or awake with self-collision on) are hashed;
//   3. broad phase: a spatial hash over those bodies' primitive boxes (object-object pairs
//      within the object pairs, and self pairs of primitives that share no medial sphere);
//   4. exact primitive tests on those pairs (radii grown by half the margin each), after a quick
//      rejection of pairs whose bounding balls are apart;
//   5. narrow phase (narrow_phase.hpp) over the colliding primitive pairs, only among the
//      surface triangles and boundary nodes of colliding primitives inside their pairs' overlap
//      regions, each candidate found and tested once however many pairs share it: exact
//      triangle-triangle intersection and, for the response, nodes against the other side's
//      triangles (closest point within the margin, or behind the triangle);
//   6. response: one contact per node, between the node and the closest point of its nearest
//      triangle (both carried by their bodies' nodes), along the triangle's normal: the contact
//      stage (runtime/pd/contact_stage.hpp) pushes both bodies with equal and opposite forces
//      inside every PD iteration.
// Phases 1, 4 and 5 run in parallel (TBB) over flat arrays kept as members, so a step allocates
// nothing once warm; per-thread results are merged in a fixed order (sorted by a total order),
// so the result does not depend on the thread count.
// Contact acts on the surface the user sees: its vertices against the other body's (or, with
// self collision, a non-adjacent part's) triangles, both carried by the tet nodes through the
// surface embedding; friction acts on their relative motion.
// Tests and benchmarks compare the pipeline with variants of it (testing all primitive pairs,
// no object-level culling, the handle bound from q: collision_variants.hpp) set through
// set_variants_for_comparison; the production pipeline always uses the defaults.

#include <memory>
#include <vector>

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"
#include "runtime/body_model.hpp"
#include "runtime/collision/collision_variants.hpp"
#include "runtime/collision/medial_bounds.hpp"
#include "runtime/collision/narrow_phase.hpp"
#include "runtime/collision/primitive_pair.hpp"
#include "runtime/collision/spatial_hash.hpp"
#include "runtime/pd/contact.hpp"
#include "runtime/pd/contact_stage.hpp"

namespace mat {

/// Self collision never pairs a surface vertex with a face of its own surface that lies within
/// this many collision margins of it in the rest shape: what touches at rest is not a contact, so
/// a body at rest stays at rest.
inline constexpr double rest_near_factor = 2.0;

struct CollisionSettings {
    bool self = true; ///< self-collision between primitives that share no sphere
    /// bound: with the exact per-vertex increments from the node positions (see
    /// CollisionVariants::bounds_from_positions); lazy: radii unchanged.
    RadiusUpdate bounds = RadiusUpdate::bound;
    double margin = 0.01; ///< contact candidate distance, relative to the largest body diagonal
    double friction = 0.3; ///< Coulomb coefficient between bodies
    /// Edge-edge contacts besides the vertex-face ones (docs/method.md, "Edge contacts").
    bool edges = false;
    /// The gap a contact between two bodies keeps, relative to the margin (PlaneCollider::offset;
    /// docs/method.md, "Skin").
    double skin = 0.0;
    /// The gap a self contact keeps, relative to the margin (docs/method.md, "Self skin").
    double self_skin = 0.0;
};

/// What the last detect() found and how long each phase took.
struct CollisionReport {
    int updated_bodies = 0; ///< bodies whose bounds were recomputed
    int object_pairs = 0; ///< pairs of bodies whose boxes meet, one of them dynamic
    int hashed_bodies = 0; ///< bodies whose primitives went to the broad phase
    int primitive_candidates = 0; ///< broad-phase pairs
    int primitive_pairs = 0; ///< pairs that pass the exact primitive test
    long triangle_tests = 0; ///< distinct triangle pairs tested (their boxes overlap)
    long node_tests = 0; ///< distinct node-triangle pairs tested
    long edge_tests = 0; ///< distinct edge-edge pairs tested
    int intersecting_triangles = 0; ///< distinct triangle pairs that intersect
    int contacts = 0; ///< contacts handed to the solvers (vertex-face and edge-edge)
    int edge_contacts = 0; ///< of which edge-edge
    /// Candidates left out: surface vertices more than the margin behind their nearest face of
    /// another body that is not constant (CollisionWorld::respond).
    int deep_vertices = 0;
    /// The deepest candidate node behind its triangle's plane at detection (m): the largest gap
    /// a contact starts from (NodeCandidate::plane). The exact depth inside the other body is
    /// `--check-collisions`' (runtime/measures/collision_check.hpp).
    double max_penetration = 0.0;
    double bounds_seconds = 0.0; ///< bounds update, surfaces and boxes in world coordinates
    double hash_seconds = 0.0; ///< broad phase
    double primitive_seconds = 0.0; ///< exact primitive tests
    double triangle_seconds = 0.0; ///< narrow phase: triangle-triangle and node-triangle tests
    double response_seconds = 0.0; ///< merge into one contact per node with its plane
    /// Adds `other`'s seconds, phase by phase.
    void add_seconds(const CollisionReport& other)
    {
        bounds_seconds += other.bounds_seconds;
        hash_seconds += other.hash_seconds;
        primitive_seconds += other.primitive_seconds;
        triangle_seconds += other.triangle_seconds;
        response_seconds += other.response_seconds;
    }
};

/// One body as the collision world sees it, in world coordinates.
struct CollisionBodyState {
    const MatX3* nodes = nullptr; ///< n x 3 node positions, in the solver's coordinates
    /// k x 3 reduced coordinates with nodes = X + B q (semi-reduced solver), or null: then the
    /// bounds are the exact per-vertex ones from the positions (as they are with q too, unless
    /// CollisionVariants::bounds_from_positions is false).
    const MatX* q = nullptr;
    Mat3 rotation = Mat3::Identity(); ///< world = R x + t for solver coordinates x
    Vec3 translation = Vec3::Zero();
    /// Gets no contacts (a mesh collider: a static, kinematic or sleeping body).
    bool is_static = false;
    /// The body has not moved since the last update: its bounds, surface and boxes are reused
    /// (a sleeping or static body; ignored before its first update).
    bool reuse_bounds = false;
    /// How far any of its nodes may move during the coming step (m; 0 for a body that does not
    /// move): its primitives grow by it and its nodes look that much farther for triangles, so
    /// that contacts that begin during the step are found at its start (speculative contacts).
    double motion = 0.0;
    /// n x 3 node velocities in the solver's coordinates (null: at rest), for the approach
    /// speed of speculative contacts (set_lookahead).
    const MatX3* velocities = nullptr;
};

class CollisionWorld {
public:
    explicit CollisionWorld(const CollisionSettings& settings);

    /// Speculative contacts: a surface vertex in front of a triangle is a candidate within the
    /// margin plus `extra` (m) plus `lookahead` (s) times its approach speed (NarrowPhase::run).
    /// Both 0 by default.
    void set_lookahead(double lookahead, double extra)
    {
        m_lookahead = lookahead;
        m_extra = extra;
    }
    /// Whether the coming detections find the intersecting triangle pairs (intersecting_pairs(),
    /// CollisionReport::intersecting_triangles; on by default): a measurement that no contact
    /// reads (NarrowPhase::set_triangle_pairs). Off, they are empty.
    void set_triangle_pairs(bool on) { m_narrow.set_triangle_pairs(on); }

    /// For tests and benchmarks: runs a variant of the pipeline to compare with (the production
    /// pipeline always uses the defaults). Set before the first detect().
    void set_variants_for_comparison(const CollisionVariants& variants) { m_variants = variants; }

    /// Adds a body (its collision data and surface embedding, kept shared). Bodies are numbered
    /// in order.
    void add_body(std::shared_ptr<const BodyModel> model);

    /// Runs the pipeline on the bodies' current states (one per added body) and returns the
    /// contacts between them: per surface vertex with a triangle near (or in front of it), the
    /// vertex against the triangle's closest point (each carried by the nodes of the surface
    /// embedding: the vertex's weights, and minus the point's), the triangle's outward normal,
    /// world coordinates (runtime/pd/contact_stage.hpp); the key of a contact is its vertex.
    /// Sorted by (body, vertex).
    const BodyContacts& detect(const std::vector<CollisionBodyState>& states);
    /// detect() during a step (the states at an iterate, no velocities): last_report(),
    /// intersecting_pairs() and world_surface() stay the step start's (what --check-collisions
    /// compares), with this detection's seconds added to the report's phases.
    const BodyContacts& detect_in_step(const std::vector<CollisionBodyState>& states);

    /// The same in two parts: phase 1 (bounds and world boxes; body_box() then holds each
    /// body's box), then phases 2 to 6 on the same bodies (their is_static may have changed in
    /// between: a woken body).
    void update_bounds(const std::vector<CollisionBodyState>& states);
    const BodyContacts& find_contacts(const std::vector<CollisionBodyState>& states);

    /// Body b's world box at the last update: its enlarged primitives' boxes, radii grown by
    /// half the margin (empty before the first update).
    const Box3& body_box(Index b) const { return m_bodies[b].box; }

    const CollisionReport& last_report() const { return m_report; }
    /// The distinct intersecting triangle pairs of the last detect(), sorted.
    const std::vector<FacePair>& intersecting_pairs() const { return m_intersecting; }
    /// Body b's surface in world coordinates at the last detect()  #Vs x 3, and its faces #F x 3.
    const MatX3& world_surface(Index b) const { return m_bodies[b].surface; }
    const MatX3i& faces(Index b) const { return m_bodies[b].model->surface().faces(); }
    const CollisionSettings& settings() const { return m_settings; }
    /// The narrow phase's vertex candidates of the last detect() (one per surface vertex, its
    /// nearest face), deep vertices included, and the margin it ran with (absolute).
    const std::vector<NodeCandidate>& node_candidates() const { return m_narrow.candidates(); }
    double margin() const { return m_margin; }
    /// Body b's enlarged primitives at the last detect(), in its solver's coordinates.
    const MedialBounds& bounds(Index b) const { return m_bodies[b].bounds; }
    Index num_bodies() const { return static_cast<Index>(m_bodies.size()); }

private:
    struct Body {
        explicit Body(std::shared_ptr<const BodyModel> body_model)
            : model(std::move(body_model))
            , bounds(model->medial(), model->primitives(), model->medial_basis(),
                  model->pd().handle_centers(), model->pd().handle_scales(),
                  model->pd().handle_column_offsets())
        {
        }
        std::shared_ptr<const BodyModel> model;
        MedialBounds bounds;
        /// detect_in_step's copy of the step start's surface (world coordinates).
        MatX3 step_surface;
        /// Surface vertices grouped by their primitive (CSR): the contact points.
        VecXi vertex_indptr; ///< #P + 1
        VecXi vertex_list;
        // Per-step workspace, world coordinates.
        MatX3 surface; ///< #Vs x 3
        /// Per surface vertex the faces of its own surface within `rest_near_radius` of it at
        /// rest (CSR, increasing; never self contacts).
        VecXi rest_near_indptr;
        VecXi rest_near_list;
        double rest_near_radius = -1.0;
        MatX3 surface_velocity; ///< #Vs x 3 (empty: at rest)
        MatX3 nodes; ///< n x 3
        MatX3 sphere_centers; ///< #S x 3 (bake coordinates)
        // Phase 1 output, kept while the body does not move.
        bool has_bounds = false;
        Box3 box; ///< union of the item boxes
        std::vector<BroadPhaseItem> items; ///< per primitive
        std::vector<Primitive> primitives; ///< per primitive, world coordinates
        std::vector<Eigen::Vector4d, Eigen::aligned_allocator<Eigen::Vector4d>> balls;
    };

    CollisionSettings m_settings;
    CollisionVariants m_variants; ///< the defaults except in tests and benchmarks
    std::vector<Body> m_bodies;
    std::vector<std::size_t> m_updated; ///< the bodies whose bounds this step recomputes
    void update_body(std::size_t b, const CollisionBodyState& state, double margin);
    void select_object_pairs(const std::vector<CollisionBodyState>& states);
    void broad_phase();
    void test_primitive_pairs(const std::vector<CollisionBodyState>& states);
    void narrow_phase(const std::vector<CollisionBodyState>& states, double margin);
    void respond(const std::vector<CollisionBodyState>& states);
    /// Appends a surface vertex's terms (its embedding's nodes) times `weight` to the contact
    /// being built.
    void add_vertex_terms(int body, int vertex, double weight);
    /// Closes the contact being built, against the plane of `normal` through 0; `face`: the
    /// first of its face's corner terms (BodyContacts::faces), or -1.
    void close_contact(const Vec3& normal, int key, bool is_self, int face = -1);
    /// Body b's faces near each vertex at rest, within `radius` (self collision skips them).
    void find_rest_neighbours(std::size_t b, double radius);

    SpatialHash m_hash;
    std::vector<BroadPhaseItem> m_items; ///< one per primitive of every hashed body
    std::vector<Primitive> m_primitives; ///< per item, world coordinates, radii + margin / 2
    /// per item, a ball holding the primitive: center x y z, radius
    std::vector<Eigen::Vector4d, Eigen::aligned_allocator<Eigen::Vector4d>> m_balls;
    std::vector<char> m_hashed; ///< per body: its items are in m_items
    std::vector<char> m_object_pair; ///< #bodies x #bodies (a < b): the pair goes on
    std::vector<ItemPair> m_pairs; ///< broad-phase candidates
    std::vector<char> m_hit; ///< per candidate: the primitives intersect
    std::vector<ItemPair> m_colliding;
    std::vector<NarrowPhaseBody> m_views; ///< per body
    std::vector<PrimitivePairRef> m_pair_refs; ///< per colliding pair
    NarrowPhase m_narrow;
    std::vector<FacePair> m_intersecting;
    BodyContacts m_contacts;
    double m_margin = 0.0; ///< absolute, from the last update_bounds
    double m_lookahead = 0.0;
    std::vector<FacePair> m_kept_intersecting; ///< detect_in_step's scratch
    std::vector<char> m_redetected; ///< detect_in_step's: per body, updated by it
    double m_extra = 0.0;
    CollisionReport m_report;
};

} // namespace mat
