#pragma once
// The contact solve as one stage of the step over all bodies (docs/method.md, "Contact").
//
// Every contact is a constraint on a relative point of one or two bodies,
//   r = sum_t w_t x_t          (terms: a node of a body and a weight),
//   gap = n . (r - p) >= 0,    Coulomb friction on r's tangential displacement since the step
//   start:
// a node against a ground plane is one term (w = 1, p on the plane); a node of body A against a
// point of body B's surface is the node (w = 1) and the point's nodes with minus its weights
// (p = 0), so one force f acts as +f on A and -f on B (Newton's third law: the total momentum
// does not change), and friction acts on the motion of A relative to B's surface. The terms of a
// body that is not stepped (static, kinematic, asleep) are constants: they go into p, and its
// motion over the step into the start of r (friction against a moving collider).
//
// The forces are solved between the bodies' global steps and their positions, in every
// iteration (Moreau-Jean non-smooth contact dynamics; runtime/pd/contact.hpp): the global step is
// linear, so forces f_d move the relative points by W_cd f_d with the Delassus operator
//   W_cd = sum over bodies b of J_cb D_b J_db^T,
// D_b body b's compliance (its global step's ContactResponse) and J_cb the weights of
// contact c's terms on b. W is isotropic (D acts alike on x, y and z). The projected Gauss-Seidel
// solve of runtime/pd/contact.hpp then runs on the relative points unchanged, with the stage as
// its ContactCoupling: W between the contacts that have been in a working set and those that have
// pushed, and the other positions through each body's summed response (docs/method.md, "W is
// never formed whole"). A contact with several terms on a body keeps the
// body's response to it, sum_t w_t z_t (a vector of the body's response size). On a reduced body
// whose responses say so, W's entries and the points are taken in node space instead
// (docs/method.md, "W in node space").

#include <array>
#include <cstdint>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/huge_pages.hpp"
#include "runtime/pd/contact.hpp"

namespace mat {

class PdSolver;

/// One node's share of a contact's relative point.
struct ContactTerm {
    int body = 0;
    int node = 0;
    double weight = 0.0;
    bool operator==(const ContactTerm& o) const
    {
        return body == o.body && node == o.node && weight == o.weight;
    }
};

/// Contacts between bodies for one step: constraint c has the terms [offsets[c], offsets[c+1])
/// and its plane (normal, point p of the relative point, friction, compliance).
struct BodyContacts {
    std::vector<ContactTerm> terms;
    std::vector<int> offsets { 0 };
    std::vector<PlaneCollider> planes;
    /// Per constraint, an index >= 0 unique among the constraints whose first term is on the
    /// same body, by which the next step's constraint is warm started with this one's force (a
    /// surface vertex); -1: the first term's node.
    std::vector<int> keys;
    /// Per constraint, whether it is a self contact (two parts of one body).
    std::vector<char> self;
    /// Per constraint, the first of its face's corner terms in `face_terms` (-1: none): the
    /// surface triangle whose outward normal its plane's normal is, as its three corners, each
    /// face_corner_terms terms on the triangle's body (weight 0 pads), in the triangle's order.
    /// The contact stage turns the plane with the iterate from them (docs/method.md, "Planes
    /// that follow the iterate").
    std::vector<int> faces;
    std::vector<ContactTerm> face_terms;
    static constexpr int face_corner_terms = 4;

    void clear()
    {
        terms.clear();
        offsets.assign(1, 0);
        planes.clear();
        keys.clear();
        self.clear();
        faces.clear();
        face_terms.clear();
    }
    Index size() const { return static_cast<Index>(planes.size()); }
    /// The body of contact c's first term (the node a collision contact is for).
    int first_body(Index c) const { return terms[static_cast<std::size_t>(offsets[c])].body; }
    /// Contacts whose first term is on `body`.
    Index count_for(int body) const
    {
        Index count = 0;
        for (Index c = 0; c < size(); ++c)
            count += first_body(c) == body ? 1 : 0;
        return count;
    }
    /// Closes the constraint made of the terms added since the last one.
    /// `face`: the first of its face's 3 x face_corner_terms terms in face_terms, or -1.
    void close(const PlaneCollider& plane, int key = -1, bool is_self = false, int face = -1)
    {
        offsets.push_back(static_cast<int>(terms.size()));
        planes.push_back(plane);
        keys.push_back(key);
        self.push_back(is_self ? 1 : 0);
        faces.push_back(face);
    }
    /// The warm start identity of constraint c: its first body, and its key (or, without one,
    /// its first node, flagged apart from keys).
    std::uint64_t identity(Index c) const
    {
        const ContactTerm& first = terms[static_cast<std::size_t>(offsets[c])];
        const int key = keys[static_cast<std::size_t>(c)];
        const std::uint64_t id = key >= 0
            ? static_cast<std::uint64_t>(key)
            : (std::uint64_t { 1 } << 31) | static_cast<std::uint64_t>(first.node);
        return (static_cast<std::uint64_t>(first.body) << 32) | id;
    }
    /// Appends the constraints of `other` whose identity none of this one's has (`scratch`:
    /// reused workspace). Contacts found again during a step keep those of its start that the
    /// new search no longer finds (docs/method.md, "Contacts found again during the step").
    void append_missing(const BodyContacts& other, std::vector<std::uint64_t>& scratch);
};

/// What a contact stage carries from one step to the next for one body: the forces its
/// contacts ended the last step with (the next step's warm start), as (node, plane) pairs (plane
/// -1: a contact between bodies, by key) and their forces  #used x 3.
struct ContactWarmStart {
    std::vector<std::array<int, 2>> used;
    MatX3 forces;
};

/// One body as the stage sees it during a step.
struct ContactBodyState {
    /// Its solver, if it is stepped this step (its begin_step() has run); null: a constant body.
    PdSolver* solver = nullptr;
    /// n x 3 positions at the start of the step and, for a constant body, during it (a
    /// kinematic body has moved to its end-of-step place already).
    const MatX3* start = nullptr;
    const MatX3* now = nullptr;
};

class ContactStage final : private ContactCoupling {
public:
    /// `num_bodies` bodies, numbered as in the terms.
    explicit ContactStage(Index num_bodies);

    /// Builds this step's constraints: every stepped body's ground contacts (its boundary nodes
    /// within its contact margin of a plane of its solver at the start of the step or at the
    /// inertia target) and `contacts`, then each body's responses and the warm start (the last
    /// step's force of the same ground pair, or of a contact at the same first node).
    /// `again`: the stage begins again during the step (its sweeps keep counting), and the
    /// first `at_iterate` of `contacts` were found at the iterate (the two points of such a
    /// contact are a closest pair there, not at the step start: their impulses' moments are taken
    /// at that iterate, see end_step()), the rest at the step's start.
    void begin_step(const std::vector<ContactBodyState>& bodies, const BodyContacts& contacts,
        bool again = false, Index at_iterate = 0);
    /// After every stepped body's global solve of one iteration: solves the forces and adds
    /// their displacements to the bodies' global steps. `last`: the step's last iteration
    /// (before it, a solve with body contacts stops after ContactSettings::early_sweeps).
    void solve(bool last = true);
    /// After the last iteration's positions: each stepped body's StepReport (contacts of which
    /// it holds the first term, the sweeps, the deepest penetration at the end of the step) and
    /// the warm start of the next step.
    void end_step();

    Index num_contacts() const { return static_cast<Index>(m_records.size()); }

    /// Body b's warm start for the next step (empty before its first step).
    ContactWarmStart warm_start(int b) const;
    /// Restores a warm_start() of body b, whose solver is `solver` (a checkpoint's). Throws
    /// mat::Error on a node or plane out of range.
    void set_warm_start(int b, PdSolver& solver, const ContactWarmStart& warm);
    /// The contact forces of the last solve  #contacts x 3 (on the first term's side).
    const MatX3& forces() const { return m_forces; }

private:
    /// A contact's terms on one stepped body.
    struct Side {
        int body = -1;
        int first = 0; ///< into m_term_node / m_term_weight
        int count = 0;
        /// Its response's column in the body's pool (-1: not formed yet this step; a side of
        /// one term has none, its response is its node's).
        int slot = -1;
        /// Its node-space response's column in the body's nodal pool (-1: not formed yet; see
        /// BodyData::nodal).
        int nodal_slot = -1;
        int dir_first
            = 0; ///< its direction (ContactResponse::direction) in m_dir_index / m_dir_value
        int dir_count = 0;
        Vec3 offset = Vec3::Zero();
    };
    struct Record {
        int num_sides = 0;
        std::array<Side, 2> sides;
        int warm_body = -1; ///< the body and node (or key) of its warm start (-1: none)
        int warm_node = 0;
        int ground_plane = -1; ///< a ground contact's plane in its body's solver, else -1
        Vec3 start = Vec3::Zero(); ///< the relative point at the step start (see add_body_contacts)
        /// A plane that follows the iterate: its face's body and the first of its corners'
        /// terms in m_face_node / m_face_weight (-1: a fixed plane).
        int face_body = -1;
        int face = -1;
        bool self = false; ///< within one body (BodyContacts::self)
        /// Found at an iterate during the step (begin_step's `at_iterate`): its impulse's moment
        /// is taken there.
        bool at_iterate = false;
    };
    struct BodyData {
        bool initialized = false;
        std::vector<int> boundary; ///< boundary nodes (ground candidates)
        double margin = 0.0; ///< absolute ground candidate distance
        /// How far behind its plane a contact's point may start a step and still take a
        /// preload (a fixed fraction of the rest bounding-box diagonal; set_preloads).
        double resting_depth = 0.0;
        /// SolverOptions::compliance_cap times the rest bounding-box diagonal (m; 0: none).
        double compliance_cap = 0.0;
        /// SolverOptions::self_push_speed times the rest diagonal and the time step (m).
        double self_push = 0.0;
        Index num_planes = 0; ///< its solver's ground planes
        MatX3 previous_ground; ///< #nodes * #planes x 3: last step's ground forces
        MatX3 previous_pair; ///< last step's contact force by key (BodyContacts::keys)
        std::vector<std::array<int, 2>> used; ///< (node, plane or -1) warm starts read
        /// The pool of multi-term sides' responses, one column each, formed when a side's is
        /// first asked for in the step (most sides never push), in blocks of pool_columns
        /// columns (huge_block_columns) that never move, in huge-page storage.
        std::vector<HugePageBlock> pool_blocks;
        Index pool_columns = 0;
        int pool_used = 0;
        std::vector<int> slots; ///< ContactResponse::direction's scratch
        /// W's entries on this body are taken in node space: a column's response as node
        /// displacements (ContactResponse::nodal_response), read at a row's terms (1 to 12
        /// nodes) instead of along its direction (the rows of q its nodes' basis rows touch,
        /// 4 to 64 on the coarse creature). Where its response says so
        /// (ContactResponse::node_space; docs/method.md, "W in node space").
        bool nodal = false;
        /// The nodal pool: per side asked for, sum_t w_t D_b e_t (n values), in blocks of
        /// nodal_columns columns (huge_block_columns) that never move, in huge-page storage.
        std::vector<HugePageBlock> nodal_blocks;
        Index nodal_columns = 0;
        int nodal_used = 0;
        /// displace()'s node positions of a nodal body (#nodes x 3): its sides' points are taken
        /// from them, and its sides have no direction.
        MatX3 displaced;
        MatX3 displacement; ///< response size x 3: its sides' responses times their forces
        /// The node positions at the iterate where the stage began again (begin_step's
        /// `again`): where the impulses' moments of the contacts found there are taken
        /// (end_step()).
        MatX3 detected;
        /// The displacement is that of the current forces over all rows (a nodal body's,
        /// from the end of the last solve): the next displace() need not sum it again.
        bool summed = false;
        MatX summing; ///< sum_responses' column-major sum over all rows (response size x 3)
        /// sum_responses' scratch: its pushing sides' responses and forces.
        struct Push {
            const double* response = nullptr;
            Eigen::RowVector3d force = Eigen::RowVector3d::Zero();
        };
        std::vector<Push> pushes;
        /// The rows of the response space its sides' directions read, increasing (empty: all;
        /// a full-space body's directions read only the contacts' nodes).
        std::vector<int> read_rows;
        std::vector<char> read_mark; ///< find_read_rows' scratch, per response row
        /// turn_planes()' node positions (#nodes x 3, those of turn_nodes valid), the nodes it
        /// takes this time, and per node the last time it took it (m_turn_stamp).
        MatX3 node_positions;
        std::vector<int> turn_nodes;
        std::vector<long> node_stamp;
        /// Sweeps through the bodies (sweep_through_bodies(), nodal bodies only): the node
        /// displacements of the force changes since they began, #nodes x 3, column-major (a
        /// push is three contiguous updates).
        MatX swept;
        /// A reduced body's 1 / A_ii per node, A its full-space system (empty: full space): the
        /// compliance floor of its self contacts (docs/method.md, "Self contacts of reduced
        /// bodies").
        VecX local_compliance;
    };

    void init_body(int b, PdSolver& solver);
    void add_ground_contacts(int b, const ContactBodyState& body);
    /// `contacts` into the step's records, the first `at_iterate` of them found at an iterate.
    void add_body_contacts(const std::vector<ContactBodyState>& bodies,
        const BodyContacts& contacts, Index at_iterate);
    void add_side(Record& record, int body, int first, int count);
    /// Contact c's face (BodyContacts::faces) into `record`, if its plane follows the iterate
    /// (record.self set: a self contact's follows it only where its body's solver says so).
    void add_face(Record& record, const std::vector<ContactBodyState>& bodies,
        const BodyContacts& contacts, Index c);
    /// The compliance floor of a self contact: sum over its terms of w^2 / A_ii on its body, 0
    /// on a full-space body.
    double self_compliance_floor(const Record& record) const;
    /// Grows a table of last forces by key (BodyData::previous_pair) to hold `key`.
    static void reach_key(MatX3& table, Index key);
    void prepare_responses(const std::vector<ContactBodyState>& bodies);
    /// Each contact between bodies' preload (from contact `first_body_contact` on), from the
    /// warm start's forces.
    void set_preloads(Index first_body_contact);
    /// Each stepped body's BodyData::read_rows.
    void find_read_rows();
    /// The side's response (pool column or node response) and the scale of its single term.
    /// Computed when first asked for in the step.
    const double* response(Side& side, double& scale);
    /// J_cb D_b applied to a response of the same body: the side's direction times it.
    double side_apply(const Side& side, const double* response) const;
    /// On a nodal body (BodyData::nodal): the side's node-space response (its nodal pool
    /// column, or its single term's nodal response) and the scale of its single term. Formed
    /// when first asked for in the step.
    const double* nodal(Side& side, double& scale);
    /// On a nodal body: J_c D_b J_d^T for two sides of it, from the nodal responses of d's
    /// terms (no pool column formed).
    double nodal_coupling(const Side& side_c, const Side& side_d);
    /// A column's contact's responses, one per side (kept for the step: a response never moves
    /// once computed), so that the rows covered later read them in parallel. On a nodal body
    /// the response is the side's nodal() one.
    struct ColumnSides {
        int count = 0;
        std::array<int, 2> body {};
        std::array<const double*, 2> response {};
        std::array<double, 2> scale {};
    };
    /// out[e] = W between contacts[e] and the contact of *columns[e], for e in [0, count):
    /// sum over the sides of both on one body of the column side's scale times side_apply(),
    /// several products at a time.
    void column_entries(
        const Index* contacts, const ColumnSides* const* columns, int count, double* out) const;
    /// The covered rows' sides, packed in row order by cover(): a new column's entries
    /// (column_rows()) then read each row's terms in one stream, not through its record.
    struct RowSides {
        int num_sides = 0;
        std::array<int, 2> body {};
        std::array<int, 2> count {};
        std::array<int, 2> first {}; ///< into m_row_index / m_row_value
    };
    /// Packs covered contact c's sides (its node terms on a nodal body, else its direction).
    void pack_row(Index c);
    /// out[r - begin] = W between the contact of row r and `column`, for r in [begin, end): the
    /// same sums, in the same order, as column_entries().
    void column_rows(const ColumnSides& column, Index begin, Index end, double* out) const;
    /// After a solve before the step's last: each plane that follows the iterate, of a contact
    /// that has been in a working set, takes its face's outward normal in the kept solutions
    /// (the iterate's positions; docs/method.md, "Planes that follow the iterate").
    void turn_planes();
    /// Each stepped body's StepReport::world_held, from this step's forces (end_step()).
    void mark_world_held();
    /// D between contacts c and d: sum over the bodies of both of J_c D_b J_d^T.
    double coupling_between(Index c, Index d);
    // ContactCoupling (runtime/pd/contact_stage_coupling.cpp).
    const VecX& diagonal() const override { return m_diagonal; }
    int cover(Index c) override;
    const double* column(Index c) override;
    void displace(const Eigen::Ref<const MatX3>& free, const Eigen::Ref<const MatX3>& forces,
        const std::vector<char>* keep, Eigen::Ref<MatX3> positions) override;
    bool sweep_through_bodies(const std::vector<Index>& working) override;
    Vec3 moved(Index c) const override;
    void push(Index c, const Vec3& delta) override;
    /// Contact c's diagonal entry W_cc, if it is not computed yet this step (it has joined a
    /// working set: m_joined).
    void ensure_diagonal(Index c);
    /// Each stepped body's displacement by `forces`: sum over its sides of z f^T (`all_rows`
    /// false: only the rows its directions read), but for the bodies whose displacement is
    /// summed already (BodyData::summed).
    void sum_responses(const Eigen::Ref<const MatX3>& forces, bool all_rows);

    std::vector<BodyData> m_data;
    std::vector<PdSolver*> m_solvers; ///< this step's, per body (null: constant)
    std::vector<Record> m_records;
    std::vector<int> m_term_node;
    std::vector<double> m_term_weight;
    std::vector<int> m_face_node; ///< the faces' corner terms (Record::face)
    std::vector<double> m_face_weight;
    std::vector<int> m_dir_index;
    std::vector<double> m_dir_value;
    std::vector<PlaneCollider> m_planes;
    std::vector<ContactPair> m_pairs; ///< (contact, its plane) for the Gauss-Seidel solve
    VecX m_diagonal; ///< W_cc  m
    /// Per contact, whether m_diagonal's entry is computed: when it first joins a working set
    /// (ensure_diagonal()), which appends it to m_joined (the planes that turn).
    std::vector<char> m_diagonal_known;
    std::vector<Index> m_joined;
    std::vector<Index> m_body_terms; ///< per body, this step's contact terms on it
    /// W's columns of the contacts that have pushed this step, over the rows of the contacts
    /// that have been in a working set (ContactCoupling), with room to grow.
    /// In huge-page storage: its first writes at an impact were thousands of page faults
    /// (docs/method.md, "Pages and wake-ups").
    HugePageBlock m_columns;
    std::vector<int> m_row_of, m_column_of; ///< per contact, its row / column (-1: none yet)
    std::vector<Index> m_rows, m_cols; ///< the contacts by row / column
    std::vector<ColumnSides> m_column_sides; ///< per column
    std::vector<RowSides> m_row_sides; ///< per row (pack_row)
    std::vector<int> m_row_index;
    std::vector<double> m_row_value;
    MatX3 m_free, m_start, m_forces, m_positions; ///< m x 3 (m_free unused: see displace())
    ContactScratch m_scratch;
    ContactSettings m_settings;
    int m_sweeps = 0;
    long m_turn_stamp = 0; ///< turn_planes() calls so far
    Index m_body_contacts = 0; ///< this step's contacts between bodies (after the ground's)
    std::vector<int> m_island_root; ///< mark_world_held's union-find, per body
    std::vector<char> m_island_held; ///< mark_world_held's, per island root
};

} // namespace mat
