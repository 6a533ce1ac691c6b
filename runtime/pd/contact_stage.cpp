#include "runtime/pd/contact_stage.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/error.hpp"
#include "common/timer.hpp"
#include "runtime/pd/solver.hpp"

namespace mat {

namespace {
    /// How far behind its plane (relative to the rest bounding-box diagonal) a contact's point
    /// may start a step and still take a preload: a tenth of the 0.5% penetration the contact
    /// aims at. Deeper, the contact is not resting (docs/method.md, "Compliance").
    constexpr double resting_depth_fraction = 5e-4;
} // namespace

ContactStage::ContactStage(Index num_bodies)
    : m_data(static_cast<std::size_t>(num_bodies))
    , m_solvers(static_cast<std::size_t>(num_bodies), nullptr)
{
}

void ContactStage::init_body(int b, PdSolver& solver)
{
    BodyData& data = m_data[static_cast<std::size_t>(b)];
    if (data.initialized)
        return;
    const Model& model = solver.model();
    const MatX3& rest = model.rest_positions();
    const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
    data.margin = solver.options().contact_margin * diagonal;
    data.resting_depth = resting_depth_fraction * diagonal;
    data.compliance_cap = solver.options().compliance_cap * diagonal;
    data.self_push = solver.options().self_push_speed * diagonal * model.time_step();
    const Index num_planes = static_cast<Index>(solver.options().planes.size());
    data.num_planes = num_planes;
    data.previous_ground = MatX3::Zero(model.num_nodes() * num_planes, 3);
    data.previous_pair = MatX3::Zero(model.num_nodes(), 3);
    data.nodal = solver.contact_response().node_space();
    if (num_planes > 0)
        data.boundary = boundary_nodes(model.tets(), model.num_nodes());
    if (solver.reduced_coordinates() != nullptr) {
        const Eigen::SparseMatrix<double>& system = model.full_system();
        data.local_compliance.resize(model.num_nodes());
        for (Index i = 0; i < model.num_nodes(); ++i)
            data.local_compliance(i) = 1.0 / system.coeff(i, i);
    }
    data.initialized = true;
}

double ContactStage::self_compliance_floor(const Record& record) const
{
    double floor = 0.0;
    for (int s = 0; s < record.num_sides; ++s) {
        const Side& side = record.sides[static_cast<std::size_t>(s)];
        const VecX& local = m_data[static_cast<std::size_t>(side.body)].local_compliance;
        if (local.size() == 0)
            continue;
        for (int t = side.first; t < side.first + side.count; ++t) {
            const double w = m_term_weight[static_cast<std::size_t>(t)];
            floor += w * w * local(m_term_node[static_cast<std::size_t>(t)]);
        }
    }
    return floor;
}

// Keys are surface vertices (and edges after them), which may exceed the nodes the table starts
// with; it grows by doubling, so that the keys of one step's contacts, met in increasing order,
// do not copy it once per key (the table's rows beyond the keys met stay zero: the same warm
// starts).
void ContactStage::reach_key(MatX3& table, Index key)
{
    if (key < table.rows())
        return;
    const Index rows = table.rows();
    table.conservativeResize(std::max(key + 1, 2 * rows), 3);
    table.bottomRows(table.rows() - rows).setZero();
}

void ContactStage::add_side(Record& record, int body, int first, int count)
{
    Side& side = record.sides[static_cast<std::size_t>(record.num_sides++)];
    side.body = body;
    side.first = first;
    side.count = count;
    side.slot = -1;
    side.nodal_slot = -1;
}

// Candidates: boundary nodes within the margin of a plane at the start of the step or at the
// inertia target (the iterates move from s towards an equilibrium near both).
void ContactStage::add_ground_contacts(int b, const ContactBodyState& body)
{
    PdSolver& solver = *body.solver;
    const BodyData& data = m_data[static_cast<std::size_t>(b)];
    const std::vector<PlaneCollider>& planes = solver.options().planes;
    const MatX3& start = *body.start;
    const MatX3& inertia = solver.inertia_target();
    const int plane_offset = static_cast<int>(m_planes.size());
    m_planes.insert(m_planes.end(), planes.begin(), planes.end());
    if (!solver.planes_near())
        return; // --device cuda: the GPU found no node near a plane (then x_n, s are not here)
    for (const int i : data.boundary)
        for (std::size_t p = 0; p < planes.size(); ++p) {
            const PlaneCollider& plane = planes[p];
            const double at_start = plane.normal.dot(start.row(i).transpose() - plane.point);
            const double at_target = plane.normal.dot(inertia.row(i).transpose() - plane.point);
            if (!(std::min(at_start, at_target) < data.margin))
                continue;
            Record record;
            add_side(record, b, static_cast<int>(m_term_node.size()), 1);
            m_term_node.push_back(i);
            m_term_weight.push_back(1.0);
            record.warm_body = b;
            record.warm_node = i;
            record.ground_plane = static_cast<int>(p);
            record.start = start.row(i).transpose();
            m_pairs.push_back(ContactPair { i, plane_offset + static_cast<int>(p) });
            m_records.push_back(record);
        }
}

// A contact's terms split by body: the stepped bodies' become sides (a node listed twice is
// merged), the constant bodies' go into the plane point and the start (docs/method.md,
// "Contact"): with r = sum_t w_t x_t over every term,
//   n . (r - p) = n . (r_stepped - (p - r_constant)),
//   r - r(start) = r_stepped - (r_stepped(start) - (r_constant(now) - r_constant(start))).
void ContactStage::add_body_contacts(
    const std::vector<ContactBodyState>& bodies, const BodyContacts& contacts, Index at_iterate)
{
    for (Index c = 0; c < contacts.size(); ++c) {
        const int begin = contacts.offsets[static_cast<std::size_t>(c)];
        const int end = contacts.offsets[static_cast<std::size_t>(c) + 1];
        PlaneCollider plane = contacts.planes[static_cast<std::size_t>(c)];
        Vec3 constant_motion = Vec3::Zero();
        Record record;
        for (int t = begin; t < end; ++t) {
            const ContactTerm& term = contacts.terms[static_cast<std::size_t>(t)];
            MAT_CHECK(term.body >= 0 && term.body < static_cast<int>(bodies.size()),
                "contact stage: contact {} names body {} of {}", c, term.body, bodies.size());
            const ContactBodyState& body = bodies[static_cast<std::size_t>(term.body)];
            if (body.solver == nullptr) {
                const Vec3 now = body.now->row(term.node).transpose();
                plane.point -= term.weight * now;
                constant_motion += term.weight * (now - body.start->row(term.node).transpose());
                continue;
            }
            Side* side = nullptr;
            for (int s = 0; s < record.num_sides; ++s)
                if (record.sides[static_cast<std::size_t>(s)].body == term.body)
                    side = &record.sides[static_cast<std::size_t>(s)];
            if (side == nullptr) {
                MAT_CHECK(record.num_sides < 2, "contact stage: contact {} spans three bodies", c);
                add_side(record, term.body, static_cast<int>(m_term_node.size()), 0);
                side = &record.sides[static_cast<std::size_t>(record.num_sides - 1)];
            }
            bool merged = false;
            for (int k = side->first; k < side->first + side->count; ++k)
                if (m_term_node[static_cast<std::size_t>(k)] == term.node) {
                    m_term_weight[static_cast<std::size_t>(k)] += term.weight;
                    merged = true;
                }
            if (!merged) {
                // A side's terms are contiguous: the terms of one body come together.
                MAT_CHECK(side == &record.sides[static_cast<std::size_t>(record.num_sides - 1)],
                    "contact stage: contact {} lists its bodies' terms interleaved", c);
                m_term_node.push_back(term.node);
                m_term_weight.push_back(term.weight);
                ++side->count;
            }
        }
        if (record.num_sides == 0)
            continue; // between constant bodies
        record.self = static_cast<std::size_t>(c) < contacts.self.size()
            && contacts.self[static_cast<std::size_t>(c)];
        record.at_iterate = c < at_iterate;
        add_face(record, bodies, contacts, c);
        if (record.self)
            plane.compliance_floor = self_compliance_floor(record);
        const ContactTerm& first = contacts.terms[static_cast<std::size_t>(begin)];
        if (bodies[static_cast<std::size_t>(first.body)].solver != nullptr) {
            const int key = contacts.keys[static_cast<std::size_t>(c)];
            record.warm_body = first.body;
            record.warm_node = key >= 0 ? key : first.node;
            reach_key(m_data[static_cast<std::size_t>(first.body)].previous_pair, record.warm_node);
        }
        // The start of the relative point, less the constant bodies' motion.
        Vec3& start = record.start;
        start = -constant_motion;
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            const MatX3& at_start = *bodies[static_cast<std::size_t>(side.body)].start;
            for (int k = side.first; k < side.first + side.count; ++k)
                start += m_term_weight[static_cast<std::size_t>(k)]
                    * at_start.row(m_term_node[static_cast<std::size_t>(k)]).transpose();
        }
        // The skin of a contact between bodies only where every stepped body keeps it
        // (SolverOptions::contact_skin; a self contact keeps its own in every mode, docs/method.md,
        // "Self skin"); the compliance's give capped where every stepped body has a cap, at the
        // skin plus the smaller cap (docs/method.md, "Compliance cap").
        bool skin = true;
        double cap = std::numeric_limits<double>::infinity();
        for (int s = 0; s < record.num_sides; ++s) {
            const auto body
                = static_cast<std::size_t>(record.sides[static_cast<std::size_t>(s)].body);
            skin = skin && bodies[body].solver->options().contact_skin;
            const double body_cap = m_data[body].compliance_cap;
            cap = body_cap > 0.0 ? std::min(cap, body_cap) : 0.0;
        }
        if (!skin && !record.self)
            plane.offset = 0.0;
        // A self contact whose vertex starts the step behind its plane pushes it out by at most
        // the body's self push in the step (docs/method.md, "Self contacts that start behind").
        if (record.self) {
            const double start_gap = plane.normal.dot(start - plane.point);
            const double push = m_data[static_cast<std::size_t>(record.sides[0].body)].self_push;
            plane.offset = std::min(plane.offset, start_gap + push);
        }
        if (!record.self && cap > 0.0)
            plane.compliance_cap = plane.offset + cap;
        m_pairs.push_back(
            ContactPair { static_cast<int>(m_records.size()), static_cast<int>(m_planes.size()) });
        m_planes.push_back(plane);
        m_records.push_back(record);
    }
}

void BodyContacts::append_missing(const BodyContacts& other, std::vector<std::uint64_t>& scratch)
{
    scratch.clear();
    for (Index c = 0; c < size(); ++c)
        scratch.push_back(identity(c));
    std::sort(scratch.begin(), scratch.end());
    for (Index c = 0; c < other.size(); ++c) {
        if (std::binary_search(scratch.begin(), scratch.end(), other.identity(c)))
            continue;
        const auto k = static_cast<std::size_t>(c);
        terms.insert(terms.end(), other.terms.begin() + other.offsets[k],
            other.terms.begin() + other.offsets[k + 1]);
        int face = -1;
        const int from = k < other.faces.size() ? other.faces[k] : -1;
        if (from >= 0) {
            face = static_cast<int>(face_terms.size());
            face_terms.insert(face_terms.end(), other.face_terms.begin() + from,
                other.face_terms.begin() + from + 3 * face_corner_terms);
        }
        close(other.planes[k], other.keys[k], k < other.self.size() && other.self[k] != 0, face);
    }
}

// A plane of a vertex against a face of a stepped body whose solver has planes_follow_iterate
// (and, for a self contact, self_planes_follow_iterate) keeps the face's corners (docs/method.md,
// "Planes that follow the iterate", "Self contacts hold their planes").
void ContactStage::add_face(Record& record, const std::vector<ContactBodyState>& bodies,
    const BodyContacts& contacts, Index c)
{
    if (static_cast<std::size_t>(c) >= contacts.faces.size())
        return;
    const int first = contacts.faces[static_cast<std::size_t>(c)];
    if (first < 0)
        return;
    constexpr int count = 3 * BodyContacts::face_corner_terms;
    MAT_CHECK(first + count <= static_cast<int>(contacts.face_terms.size()),
        "contact stage: contact {} names face terms past the end", c);
    const int body = contacts.face_terms[static_cast<std::size_t>(first)].body;
    MAT_CHECK(body >= 0 && body < static_cast<int>(bodies.size()),
        "contact stage: contact {} names body {} of {}", c, body, bodies.size());
    const PdSolver* solver = bodies[static_cast<std::size_t>(body)].solver;
    if (solver == nullptr || !solver->options().planes_follow_iterate
        || (record.self && !solver->options().self_planes_follow_iterate))
        return;
    record.face_body = body;
    record.face = static_cast<int>(m_face_node.size());
    for (int t = first; t < first + count; ++t) {
        const ContactTerm& term = contacts.face_terms[static_cast<std::size_t>(t)];
        MAT_CHECK(term.body == body, "contact stage: contact {}'s face spans two bodies", c);
        m_face_node.push_back(term.node);
        m_face_weight.push_back(term.weight);
    }
}

void ContactStage::begin_step(const std::vector<ContactBodyState>& bodies,
    const BodyContacts& contacts, bool again, Index at_iterate)
{
    MAT_CHECK(bodies.size() == m_data.size(), "contact stage: {} bodies for {}", bodies.size(),
        m_data.size());
    m_records.clear();
    m_term_node.clear();
    m_term_weight.clear();
    m_face_node.clear();
    m_face_weight.clear();
    m_planes.clear();
    m_pairs.clear();
    m_settings = ContactSettings {};
    for (BodyData& data : m_data)
        data.summed = false;
    bool first_solver = true;
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        m_solvers[b] = bodies[b].solver;
        if (bodies[b].solver == nullptr)
            continue;
        init_body(static_cast<int>(b), *bodies[b].solver);
        if (again)
            m_data[b].detected = bodies[b].solver->step_positions();
        const ContactSettings& settings = bodies[b].solver->options().contact;
        m_settings.max_sweeps = first_solver ? settings.max_sweeps
                                             : std::max(m_settings.max_sweeps, settings.max_sweeps);
        m_settings.tolerance = first_solver ? settings.tolerance
                                            : std::min(m_settings.tolerance, settings.tolerance);
        m_settings.through_bodies = first_solver
            ? settings.through_bodies
            : std::max(m_settings.through_bodies, settings.through_bodies);
        m_settings.subspace_every = first_solver
            ? settings.subspace_every
            : std::max(m_settings.subspace_every, settings.subspace_every);
        first_solver = false;
    }
    for (std::size_t b = 0; b < bodies.size(); ++b)
        if (bodies[b].solver != nullptr && !bodies[b].solver->options().planes.empty())
            add_ground_contacts(static_cast<int>(b), bodies[b]);
    const Index ground = static_cast<Index>(m_records.size());
    add_body_contacts(bodies, contacts, at_iterate);
    m_body_contacts = static_cast<Index>(m_records.size()) - ground;
    for (std::size_t a = static_cast<std::size_t>(ground); a < m_records.size(); ++a) {
        // Contacts between bodies are compliant (PdSolver's node_contact_compliance).
        const Side& side = m_records[a].sides[0];
        m_planes[static_cast<std::size_t>(m_pairs[a].plane)].compliance
            = m_solvers[static_cast<std::size_t>(side.body)]->options().node_contact_compliance;
    }

    const Index m = static_cast<Index>(m_records.size());
    if (m_free.rows() != m) {
        m_diagonal.resize(m);
        m_free = MatX3::Zero(m, 3); // not read: displace() takes the kept solutions
        m_start.resize(m, 3);
        m_forces.resize(m, 3);
        m_positions.resize(m, 3);
    }
    for (Index a = 0; a < m; ++a)
        m_start.row(a) = m_records[static_cast<std::size_t>(a)].start.transpose();
    prepare_responses(bodies);
    // Nothing of W yet: a contact's diagonal entry and responses when it joins a working set
    // (cover()), its column when it first pushes (column()).
    m_diagonal.setZero();
    m_diagonal_known.assign(static_cast<std::size_t>(m), 0);
    m_joined.clear();
    m_row_of.assign(static_cast<std::size_t>(m), -1);
    m_column_of.assign(static_cast<std::size_t>(m), -1);
    m_rows.clear();
    m_cols.clear();
    m_column_sides.clear();
    m_row_sides.clear();
    m_row_index.clear();
    m_row_value.clear();
    // Warm start: the last step's forces; then forget them, so that a contact that drops out
    // and comes back later does not start from a stale force (end_step writes the current ones).
    for (Index a = 0; a < m; ++a) {
        const Record& record = m_records[static_cast<std::size_t>(a)];
        m_forces.row(a).setZero();
        if (record.warm_body < 0)
            continue;
        const BodyData& data = m_data[static_cast<std::size_t>(record.warm_body)];
        const Index planes = static_cast<Index>(
            m_solvers[static_cast<std::size_t>(record.warm_body)]->options().planes.size());
        m_forces.row(a) = record.ground_plane >= 0
            ? data.previous_ground.row(record.warm_node * planes + record.ground_plane)
            : data.previous_pair.row(record.warm_node);
    }
    set_preloads(ground);
    for (std::size_t b = 0; b < m_data.size(); ++b) {
        BodyData& data = m_data[b];
        if (m_solvers[b] == nullptr)
            continue;
        const Index planes = static_cast<Index>(m_solvers[b]->options().planes.size());
        for (const auto& [node, plane] : data.used) {
            if (plane >= 0)
                data.previous_ground.row(node * planes + plane).setZero();
            else
                data.previous_pair.row(node).setZero();
        }
        data.used.clear();
    }
    if (!again)
        m_sweeps = 0; // a step's sweeps count over both of its contact sets
}

// A contact between bodies takes the normal force of its warm start (the last step's of the same
// key) as its preload when every body it pushes has compliance_preload. A self contact never does
// (docs/method.md, "Self collision on real meshes": the preload fed on itself there).
void ContactStage::set_preloads(Index first_body_contact)
{
    const Index m = static_cast<Index>(m_records.size());
    for (Index a = first_body_contact; a < m; ++a) {
        const Record& record = m_records[static_cast<std::size_t>(a)];
        // A point that starts the step further behind its plane than a resting contact sits
        // (the smaller of its bodies' resting depths) is not resting: it keeps the plain
        // compliance, so that a contact that cannot be met is not hardened step after step.
        bool preload = !record.self;
        double depth = std::numeric_limits<double>::infinity();
        for (int s = 0; s < record.num_sides; ++s) {
            const auto body
                = static_cast<std::size_t>(record.sides[static_cast<std::size_t>(s)].body);
            preload = preload && m_solvers[body]->options().compliance_preload;
            depth = std::min(depth, m_data[body].resting_depth);
        }
        PlaneCollider& plane = m_planes[static_cast<std::size_t>(m_pairs[a].plane)];
        preload = preload && plane.normal.dot(m_start.row(a).transpose() - plane.point) >= -depth;
        plane.preload
            = preload ? std::max(0.0, plane.normal.dot(m_forces.row(a).transpose())) : 0.0;
    }
}

void ContactStage::prepare_responses(const std::vector<ContactBodyState>& bodies)
{
    // A side with several terms gets a pool column for its response sum_t w_t z_t when it is
    // first asked for; the node responses z_j are the bodies' own, also computed when asked for.
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        m_data[b].pool_used = 0;
        m_data[b].nodal_used = 0;
        if (bodies[b].solver != nullptr)
            bodies[b].solver->contact_response().begin_contacts();
    }
    std::vector<Index>& terms = m_body_terms;
    terms.assign(bodies.size(), 0);
    for (Record& record : m_records)
        for (int s = 0; s < record.num_sides; ++s) {
            Side& side = record.sides[static_cast<std::size_t>(s)];
            terms[static_cast<std::size_t>(side.body)] += side.count;
            side.slot = -1;
        }
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        if (bodies[b].solver == nullptr)
            continue;
        BodyData& data = m_data[b];
        // A body with contact candidates runs its iterations plain (docs/method.md).
        bodies[b].solver->set_contact_nodes(terms[b]);
        const Index size = bodies[b].solver->contact_response().response_size();
        if (!data.pool_blocks.empty() && data.pool_blocks.front().rows() != size)
            data.pool_blocks.clear();
    }
    // Each side's direction.
    m_dir_index.clear();
    m_dir_value.clear();
    for (Record& record : m_records)
        for (int s = 0; s < record.num_sides; ++s) {
            Side& side = record.sides[static_cast<std::size_t>(s)];
            BodyData& body = m_data[static_cast<std::size_t>(side.body)];
            side.dir_first = static_cast<int>(m_dir_index.size());
            side.dir_count = 0;
            if (body.nodal)
                continue;
            const ContactResponse& step
                = m_solvers[static_cast<std::size_t>(side.body)]->contact_response();
            body.slots.resize(static_cast<std::size_t>(step.response_size()), -1);
            step.direction(m_term_node.data() + side.first, m_term_weight.data() + side.first,
                side.count, m_dir_index, m_dir_value, side.offset, body.slots);
            side.dir_count = static_cast<int>(m_dir_index.size()) - side.dir_first;
        }
    find_read_rows();
}

const double* ContactStage::response(Side& side, double& scale)
{
    ContactResponse& global = m_solvers[static_cast<std::size_t>(side.body)]->contact_response();
    if (side.count == 1) {
        scale = m_term_weight[static_cast<std::size_t>(side.first)];
        return global.node_response(m_term_node[static_cast<std::size_t>(side.first)]).data();
    }
    scale = 1.0;
    BodyData& data = m_data[static_cast<std::size_t>(side.body)];
    const bool fresh = side.slot < 0;
    if (fresh) {
        side.slot = data.pool_used++;
        if (data.pool_blocks.empty())
            data.pool_columns = huge_block_columns(global.response_size());
        if (side.slot >= static_cast<Index>(data.pool_blocks.size()) * data.pool_columns)
            data.pool_blocks.emplace_back(global.response_size(), data.pool_columns);
    }
    Eigen::Map<VecX> column(
        data.pool_blocks[static_cast<std::size_t>(side.slot / data.pool_columns)].col(
            side.slot % data.pool_columns),
        global.response_size());
    if (fresh) {
        column.setZero();
        for (int k = side.first; k < side.first + side.count; ++k)
            column.noalias() += m_term_weight[static_cast<std::size_t>(k)]
                * global.node_response(m_term_node[static_cast<std::size_t>(k)]);
    }
    return column.data();
}

const double* ContactStage::nodal(Side& side, double& scale)
{
    ContactResponse& global = m_solvers[static_cast<std::size_t>(side.body)]->contact_response();
    if (side.count == 1) {
        scale = m_term_weight[static_cast<std::size_t>(side.first)];
        return global.nodal_response(m_term_node[static_cast<std::size_t>(side.first)]).data();
    }
    scale = 1.0;
    BodyData& data = m_data[static_cast<std::size_t>(side.body)];
    const bool fresh = side.nodal_slot < 0;
    if (fresh) {
        side.nodal_slot = data.nodal_used++;
        const Index nodes = m_solvers[static_cast<std::size_t>(side.body)]->model().num_nodes();
        if (data.nodal_blocks.empty())
            data.nodal_columns = huge_block_columns(nodes);
        if (side.nodal_slot >= static_cast<Index>(data.nodal_blocks.size()) * data.nodal_columns)
            data.nodal_blocks.emplace_back(nodes, data.nodal_columns);
    }
    Eigen::Map<VecX> column(
        data.nodal_blocks[static_cast<std::size_t>(side.nodal_slot / data.nodal_columns)].col(
            side.nodal_slot % data.nodal_columns),
        m_solvers[static_cast<std::size_t>(side.body)]->model().num_nodes());
    if (fresh) {
        column.setZero();
        for (int k = side.first; k < side.first + side.count; ++k)
            column.noalias() += m_term_weight[static_cast<std::size_t>(k)]
                * global.nodal_response(m_term_node[static_cast<std::size_t>(k)]);
    }
    return column.data();
}

double ContactStage::nodal_coupling(const Side& side_c, const Side& side_d)
{
    ContactResponse& global = m_solvers[static_cast<std::size_t>(side_d.body)]->contact_response();
    double sum = 0.0;
    for (int s = side_d.first; s < side_d.first + side_d.count; ++s) {
        const double* moved
            = global.nodal_response(m_term_node[static_cast<std::size_t>(s)]).data();
        double inner = 0.0;
        for (int t = side_c.first; t < side_c.first + side_c.count; ++t)
            inner += m_term_weight[static_cast<std::size_t>(t)]
                * moved[m_term_node[static_cast<std::size_t>(t)]];
        sum += m_term_weight[static_cast<std::size_t>(s)] * inner;
    }
    return sum;
}

double ContactStage::side_apply(const Side& side, const double* z) const
{
    double sum = 0.0;
    for (int i = side.dir_first; i < side.dir_first + side.dir_count; ++i)
        sum += m_dir_value[static_cast<std::size_t>(i)]
            * z[m_dir_index[static_cast<std::size_t>(i)]];
    return sum;
}

void ContactStage::solve(bool last)
{
    const Index m = static_cast<Index>(m_records.size());
    if (m == 0)
        return;
    Timer timer;
    // Body contacts: the iterations before the last take at most early_sweeps sweeps (the PD
    // iterate they push still moves; the last iteration's solve is the one that must hold), and
    // no subspace steps: one that converges there pays a pass over every candidate to see which
    // join, and cost more than it saved (docs/method.md, "Subspace steps").
    ContactSettings settings = m_settings;
    settings.outside_positions = false; // only the forces are read below
    if (!last && m_body_contacts > 0) {
        settings.max_sweeps = std::min(settings.max_sweeps, settings.early_sweeps);
        settings.subspace_every = 0;
    }
    // The compliance caps bind in the step's last solve only: bound in every solve, they
    // crushed full-space bodies and strained hyper-reduced ones (docs/method.md,
    // "Compliance cap").
    settings.compliance_caps = last;
    const ContactSolveResult result = solve_plane_contacts(
        *this, m_planes, m_pairs, m_free, m_start, m_forces, m_positions, settings, m_scratch);
    m_sweeps += result.sweeps;
    for (BodyData& data : m_data)
        data.summed = false;
    sum_responses(m_forces, true);
    // A nodal body's displace() takes all rows, as here: the next solve starts from these
    // forces, so its first displace() reads this sum (the same bits).
    for (BodyData& data : m_data)
        data.summed = data.nodal;
    for (std::size_t b = 0; b < m_data.size(); ++b)
        if (m_solvers[b] != nullptr)
            m_solvers[b]->contact_response().add_displacement(m_data[b].displacement);
    if (!last)
        turn_planes();
    // The solve's time goes to the stepped bodies in equal shares.
    int stepped = 0;
    for (const PdSolver* solver : m_solvers)
        stepped += solver != nullptr ? 1 : 0;
    const double share = timer.seconds() / std::max(stepped, 1);
    for (PdSolver* solver : m_solvers)
        if (solver != nullptr)
            solver->add_contact_seconds(share);
}

void ContactStage::end_step()
{
    for (PdSolver* solver : m_solvers)
        if (solver != nullptr) {
            solver->report().contacts = 0;
            solver->report().active_contacts = 0;
            solver->report().contact_sweeps = m_sweeps;
            solver->report().max_penetration = 0.0;
            solver->report().contact_impulse.setZero();
            solver->report().contact_moment.setZero();
            solver->report().world_contact = false;
            solver->report().world_held = false;
        }
    const Index m = static_cast<Index>(m_records.size());
    for (Index a = 0; a < m; ++a) {
        const Record& record = m_records[static_cast<std::size_t>(a)];
        if (record.warm_body >= 0) {
            BodyData& data = m_data[static_cast<std::size_t>(record.warm_body)];
            const Index planes = static_cast<Index>(
                m_solvers[static_cast<std::size_t>(record.warm_body)]->options().planes.size());
            if (record.ground_plane >= 0)
                data.previous_ground.row(record.warm_node * planes + record.ground_plane)
                    = m_forces.row(a);
            else
                data.previous_pair.row(record.warm_node) = m_forces.row(a);
            data.used.push_back({ record.warm_node, record.ground_plane });
        }
        // The relative point at the end of the step, from the bodies' positions.
        Vec3 x = Vec3::Zero();
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            const MatX3& positions
                = m_solvers[static_cast<std::size_t>(side.body)]->step_positions();
            for (int k = side.first; k < side.first + side.count; ++k)
                x += m_term_weight[static_cast<std::size_t>(k)]
                    * positions.row(m_term_node[static_cast<std::size_t>(k)]).transpose();
        }
        // Each side takes the force times its weights' sum (1 for a point of the body, -1 for
        // the other body's point).
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            PdSolver& solver = *m_solvers[static_cast<std::size_t>(side.body)];
            double weight = 0.0;
            for (int k = side.first; k < side.first + side.count; ++k)
                weight += m_term_weight[static_cast<std::size_t>(k)];
            const double h = solver.model().time_step();
            solver.report().contact_impulse += (weight * h) * m_forces.row(a).transpose();
            // Pushed by the world: a ground plane, or a body that is not stepped.
            if (record.num_sides == 1 && std::abs(weight) > 0.5
                && m_forces.row(a).squaredNorm() > 0.0)
                solver.report().world_contact = true;
            // Its moment at the start of the step, about the origin
            // (runtime/pd/angular_momentum.hpp), where its two points are a closest pair along
            // it (so that the two sides' moments of a normal force cancel); for contacts found
            // at an iterate, at that iterate.
            const MatX3& begin = record.at_iterate
                ? m_data[static_cast<std::size_t>(side.body)].detected
                : solver.step_start_positions();
            for (int k = side.first; k < side.first + side.count; ++k) {
                const Index node = m_term_node[static_cast<std::size_t>(k)];
                solver.report().contact_moment += begin.row(node).transpose().cross(
                    (m_term_weight[static_cast<std::size_t>(k)] * h) * m_forces.row(a).transpose());
            }
        }
        const PlaneCollider& plane = m_planes[static_cast<std::size_t>(m_pairs[a].plane)];
        StepReport& report = m_solvers[static_cast<std::size_t>(record.sides[0].body)]->report();
        ++report.contacts;
        if (m_forces.row(a).squaredNorm() > 0.0)
            ++report.active_contacts;
        report.max_penetration
            = std::max(report.max_penetration, -plane.normal.dot(x - plane.point));
    }
    mark_world_held();
}

// Contact islands by union-find over the stepped bodies, joined by the contacts that pushed;
// an island with a body that the world pushed or that has pins is held, every body of it.
void ContactStage::mark_world_held()
{
    std::vector<int>& root = m_island_root;
    root.resize(m_solvers.size());
    for (std::size_t b = 0; b < root.size(); ++b)
        root[b] = static_cast<int>(b);
    const auto find = [&root](int b) {
        while (root[static_cast<std::size_t>(b)] != b)
            b = root[static_cast<std::size_t>(b)]
                = root[static_cast<std::size_t>(root[static_cast<std::size_t>(b)])];
        return b;
    };
    for (std::size_t a = 0; a < m_records.size(); ++a) {
        const Record& record = m_records[a];
        if (record.num_sides == 2 && m_forces.row(static_cast<Index>(a)).squaredNorm() > 0.0) {
            const int p = find(record.sides[0].body), q = find(record.sides[1].body);
            root[static_cast<std::size_t>(std::max(p, q))] = std::min(p, q);
        }
    }
    std::vector<char>& held = m_island_held;
    held.assign(m_solvers.size(), 0);
    for (std::size_t b = 0; b < m_solvers.size(); ++b) {
        PdSolver* solver = m_solvers[b];
        if (solver != nullptr
            && (solver->report().world_contact || !solver->model().pinned_nodes().empty()))
            held[static_cast<std::size_t>(find(static_cast<int>(b)))] = 1;
    }
    for (std::size_t b = 0; b < m_solvers.size(); ++b)
        if (m_solvers[b] != nullptr)
            m_solvers[b]->report().world_held
                = held[static_cast<std::size_t>(find(static_cast<int>(b)))] != 0;
}

} // namespace mat
