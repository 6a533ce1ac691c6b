#include "runtime/collision/narrow_phase.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "runtime/collision/triangle_tests.hpp"

namespace mat {
namespace {

    using Item = NarrowPhase::Item;

    /// The work lists are split into this many chunks (enough for load balance on a few
    /// threads), each with its own results: they do not depend on the thread split.
    constexpr int work_chunks = 64;
    bool boxes_overlap(const Box3& a, const Box3& b)
    {
        return (a.min().x() <= b.max().x()) & (a.min().y() <= b.max().y())
            & (a.min().z() <= b.max().z()) & (b.min().x() <= a.max().x())
            & (b.min().y() <= a.max().y()) & (b.min().z() <= a.max().z());
    }

    Vec3 corner(const NarrowPhaseBody& body, int f, int c)
    {
        return body.surface->row((*body.faces)(f, c)).transpose();
    }

    Box3 face_box(const NarrowPhaseBody& body, int f)
    {
        const Vec3 a = corner(body, f, 0);
        const Vec3 b = corner(body, f, 1);
        const Vec3 c = corner(body, f, 2);
        return Box3(a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c));
    }

    std::uint64_t pair_key(int a, int b)
    {
        const int lo = std::min(a, b);
        const int hi = std::max(a, b);
        return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(lo)) << 32)
            | static_cast<std::uint32_t>(hi);
    }

    /// Appends `value` to `list` once per run: stamps[value] holds the run that added it.
    void add_once(std::vector<int>& stamps, int value, int run, std::vector<int>& list)
    {
        int& stamp = stamps[static_cast<std::size_t>(value)];
        if (stamp != run) {
            stamp = run;
            list.push_back(value);
        }
    }

    template <class T> void sort_unique(std::vector<T>& v)
    {
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
    }

} // namespace

void NarrowPhase::prepare(const std::vector<NarrowPhaseBody>& bodies)
{
    m_bodies.resize(bodies.size());
    for (std::size_t b = 0; b < bodies.size(); ++b) {
        const NarrowPhaseBody& body = bodies[b];
        BodyData& data = m_bodies[b];
        const Index num_primitives = body.face_indptr->size() - 1;
        if (static_cast<Index>(data.stamp.size()) == num_primitives
            && static_cast<Index>(data.face_stamp.size()) == body.faces->rows()
            && data.node_primitive.size() == body.nodes->rows()
            && (!m_edge_contacts || !body.nodes_are_vertices || !data.edges.vertices.empty()))
            continue;
        // First run for this body: sizes and the inverse maps (face -> primitives, node ->
        // primitive).
        data.stamp.assign(static_cast<std::size_t>(num_primitives), -1);
        data.region.assign(static_cast<std::size_t>(num_primitives), Box3());
        data.self_region.assign(static_cast<std::size_t>(num_primitives), Box3());
        data.face_kinds.assign(static_cast<std::size_t>(body.faces->rows()), 0);
        data.patch.assign(static_cast<std::size_t>(num_primitives), Box3());
        data.patch_stamp.assign(static_cast<std::size_t>(num_primitives), -1);
        data.patched.reserve(static_cast<std::size_t>(num_primitives));
        data.face_stamp.assign(static_cast<std::size_t>(body.faces->rows()), -1);
        data.face_position.assign(static_cast<std::size_t>(body.faces->rows()), -1);
        data.self_row.assign(static_cast<std::size_t>(num_primitives), -1);
        data.self_rowed.clear();
        const VecXi& indptr = *body.face_indptr;
        const VecXi& list = *body.face_list;
        data.face_primitive_indptr = VecXi::Zero(body.faces->rows() + 1);
        for (Index j = 0; j < list.size(); ++j)
            ++data.face_primitive_indptr(list(j) + 1);
        for (Index f = 0; f < body.faces->rows(); ++f)
            data.face_primitive_indptr(f + 1) += data.face_primitive_indptr(f);
        data.face_primitives.resize(list.size());
        VecXi fill = data.face_primitive_indptr.head(body.faces->rows());
        for (Index p = 0; p < num_primitives; ++p)
            for (int j = indptr(p); j < indptr(p + 1); ++j)
                data.face_primitives(fill(list(j))++) = static_cast<int>(p);
        data.node_primitive = VecXi::Constant(body.nodes->rows(), -1);
        for (Index p = 0; p < num_primitives; ++p)
            for (int j = (*body.node_indptr)(p); j < (*body.node_indptr)(p + 1); ++j)
                data.node_primitive((*body.node_list)(j)) = static_cast<int>(p);
        data.grid.items.reserve(static_cast<std::size_t>(body.faces->rows()));
        data.nodes.reserve(static_cast<std::size_t>(body.node_list->size()));
        data.partners.reserve(bodies.size());
        data.active.reserve(static_cast<std::size_t>(num_primitives));
        if (m_edge_contacts && body.nodes_are_vertices)
            find_sharp_edges(body, data);
    }
}

void NarrowPhase::activate(const std::vector<NarrowPhaseBody>& bodies,
    const std::vector<PrimitivePairRef>& pairs, double margin, double lookahead, double extra)
{
    ++m_run;
    for (BodyData& data : m_bodies) {
        data.active.clear();
        data.grid.items.clear();
        data.nodes.clear();
        data.partners.clear();
        if (data.partner_stamp.size() != m_bodies.size())
            data.partner_stamp.assign(m_bodies.size(), -1);
        data.self_pairs.clear();
    }
    // Each primitive's region: the union of its pairs' regions, grown, each within reach of the
    // partner's patch.
    compute_patches(bodies, pairs);
    for (const PrimitivePairRef& pair : pairs)
        add_pair(bodies, pair, margin, lookahead, extra);
    // The active triangles and nodes: those of an active primitive inside its region (a
    // triangle enclosed by several primitives is taken once). In parallel over the bodies.
    for_each_body(
        bodies, [&](const NarrowPhaseBody& body, BodyData& data) { collect_active(body, data); });
    // The sweep axis: the shortest side of the active triangles' box (the columns then divide
    // the two longer sides and a column is short; measured faster than the longest side on every
    // scene tried, docs/method.md). Across it, a grid of columns per size class of triangles
    // (cells at least twice as wide as the class's widest triangle, so that a triangle is filed
    // in the column of its low corner and looked up in the neighbouring ones); within a column,
    // the triangles are sorted along the sweep axis.
    choose_sweep_axis();
    const int axis = m_axis;
    for_each_body(bodies, [&](const NarrowPhaseBody& body, BodyData& data) {
        file_faces(body, data, axis);
        collect_active_edges(body, data, axis);
        std::sort(data.partners.begin(), data.partners.end());
        sort_unique(data.self_pairs);
        mark_self_rows(body, data);
    });
}

void NarrowPhase::mark_self_rows(const NarrowPhaseBody& body, BodyData& data) const
{
    for (const int p : data.self_rowed)
        data.self_row[static_cast<std::size_t>(p)] = -1;
    data.self_rowed.clear();
    data.self_bits.clear();
    if (data.self_pairs.empty())
        return;
    const std::size_t n = data.grid.items.size();
    for (std::size_t k = 0; k < n; ++k)
        data.face_position[static_cast<std::size_t>(data.grid.at(k).index)] = static_cast<int>(k);
    const auto row_of = [&](int p) {
        int& row = data.self_row[static_cast<std::size_t>(p)];
        if (row < 0) {
            row = static_cast<int>(data.self_rowed.size());
            data.self_rowed.push_back(p);
        }
        return row;
    };
    for (const std::uint64_t key : data.self_pairs) {
        row_of(static_cast<int>(key >> 32));
        row_of(static_cast<int>(key & 0xffffffffu));
    }
    // Past 32 MB of rows (a huge body with many self pairs), the binary searches of
    // self_pair_allowed instead.
    data.self_words = (n + 63) / 64;
    const std::size_t words = data.self_rowed.size() * data.self_words;
    constexpr std::size_t most_words = std::size_t { 1 } << 22;
    if (words > most_words)
        return;
    data.self_bits.assign(words, 0);
    // Each row's partners (CSR), then the rows in parallel: each row is written by one task,
    // so the bits do not depend on the thread count.
    const std::size_t rows = data.self_rowed.size();
    data.row_partner_start.assign(rows + 1, 0);
    for (const std::uint64_t key : data.self_pairs) {
        ++data.row_partner_start[static_cast<std::size_t>(
                                     data.self_row[static_cast<std::size_t>(key >> 32)])
            + 1];
        ++data.row_partner_start[static_cast<std::size_t>(
                                     data.self_row[static_cast<std::size_t>(key & 0xffffffffu)])
            + 1];
    }
    for (std::size_t r = 0; r < rows; ++r)
        data.row_partner_start[r + 1] += data.row_partner_start[r];
    data.row_partners.resize(static_cast<std::size_t>(data.row_partner_start[rows]));
    data.row_fill.assign(data.row_partner_start.begin(), data.row_partner_start.end() - 1);
    for (const std::uint64_t key : data.self_pairs) {
        const int lo = static_cast<int>(key >> 32);
        const int hi = static_cast<int>(key & 0xffffffffu);
        data.row_partners[static_cast<std::size_t>(
            data.row_fill[static_cast<std::size_t>(data.self_row[static_cast<std::size_t>(lo)])]++)]
            = hi;
        data.row_partners[static_cast<std::size_t>(
            data.row_fill[static_cast<std::size_t>(data.self_row[static_cast<std::size_t>(hi)])]++)]
            = lo;
    }
    // Each rowed primitive's active faces as words of bits over the positions (at most one
    // word per face: a segment of that many per row), then each row as the union of its
    // partners' words.
    data.row_word_start.resize(rows + 1);
    data.row_word_start[0] = 0;
    for (std::size_t r = 0; r < rows; ++r) {
        const int p = data.self_rowed[r];
        data.row_word_start[r + 1]
            = data.row_word_start[r] + (*body.face_indptr)(p + 1) - (*body.face_indptr)(p);
    }
    data.row_word_count.resize(rows);
    data.row_word_index.resize(static_cast<std::size_t>(data.row_word_start[rows]));
    data.row_word_bits.resize(static_cast<std::size_t>(data.row_word_start[rows]));
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows, 8),
        [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t r = range.begin(); r != range.end(); ++r)
                primitive_words(body, data, r);
        });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows, 4),
        [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t r = range.begin(); r != range.end(); ++r) {
                std::uint64_t* bits = data.self_bits.data() + r * data.self_words;
                for (int j = data.row_partner_start[r]; j < data.row_partner_start[r + 1]; ++j) {
                    const std::size_t pr
                        = static_cast<std::size_t>(data.self_row[static_cast<std::size_t>(
                            data.row_partners[static_cast<std::size_t>(j)])]);
                    const int begin = data.row_word_start[pr];
                    const int end = begin + data.row_word_count[pr];
                    for (int w = begin; w < end; ++w)
                        bits[data.row_word_index[static_cast<std::size_t>(w)]]
                            |= data.row_word_bits[static_cast<std::size_t>(w)];
                }
            }
        });
}

void NarrowPhase::primitive_words(const NarrowPhaseBody& body, BodyData& data, std::size_t r) const
{
    // The positions of the primitive's active faces, sorted in its segment, then merged by word.
    const int p = data.self_rowed[r];
    const std::size_t begin = static_cast<std::size_t>(data.row_word_start[r]);
    std::uint32_t* positions = data.row_word_index.data() + begin;
    std::size_t count = 0;
    for (int i = (*body.face_indptr)(p); i < (*body.face_indptr)(p + 1); ++i) {
        const int f = (*body.face_list)(i);
        if (data.face_stamp[static_cast<std::size_t>(f)] == m_run)
            positions[count++]
                = static_cast<std::uint32_t>(data.face_position[static_cast<std::size_t>(f)]);
    }
    std::sort(positions, positions + count);
    std::size_t words = 0;
    for (std::size_t i = 0; i < count; ++i) {
        const std::uint32_t word = positions[i] / 64;
        const std::uint64_t bit = std::uint64_t { 1 } << (positions[i] % 64);
        if (words > 0 && data.row_word_index[begin + words - 1] == word) {
            data.row_word_bits[begin + words - 1] |= bit;
        } else {
            data.row_word_index[begin + words] = word;
            data.row_word_bits[begin + words] = bit;
            ++words;
        }
    }
    data.row_word_count[r] = static_cast<int>(words);
}

template <class Work>
void NarrowPhase::for_each_body(const std::vector<NarrowPhaseBody>& bodies, const Work& work)
{
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m_bodies.size(), 1),
        [&](const tbb::blocked_range<std::size_t>& range) {
            for (std::size_t b = range.begin(); b != range.end(); ++b)
                work(bodies[b], m_bodies[b]);
        });
}

void NarrowPhase::compute_patches(
    const std::vector<NarrowPhaseBody>& bodies, const std::vector<PrimitivePairRef>& pairs)
{
    for (BodyData& data : m_bodies)
        data.patched.clear();
    // Only pairs between two bodies are cut to the patches: within one body the cut kept nearly
    // every face active (docs/method.md, section 4, step 5) and was only a cost.
    for (const PrimitivePairRef& pair : pairs) {
        if (pair.body_a == pair.body_b)
            continue;
        for (const auto& [b, p] : { std::pair(pair.body_a, pair.primitive_a),
                 std::pair(pair.body_b, pair.primitive_b) }) {
            BodyData& data = m_bodies[static_cast<std::size_t>(b)];
            add_once(data.patch_stamp, p, m_run, data.patched);
        }
    }
    // Each patch written by one task; each body's fastest node.
    for_each_body(bodies, [&](const NarrowPhaseBody& body, BodyData& data) {
        data.fastest = 0.0;
        if (body.velocities != nullptr && !data.patched.empty())
            data.fastest = std::sqrt(body.velocities->rowwise().squaredNorm().maxCoeff());
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, data.patched.size(), 16),
            [&](const tbb::blocked_range<std::size_t>& range) {
                for (std::size_t k = range.begin(); k != range.end(); ++k) {
                    const int p = data.patched[k];
                    Box3 box;
                    for (int j = (*body.face_indptr)(p); j < (*body.face_indptr)(p + 1); ++j)
                        box.extend(face_box(body, (*body.face_list)(j)));
                    for (int j = (*body.node_indptr)(p); j < (*body.node_indptr)(p + 1); ++j)
                        box.extend(Vec3(body.nodes->row((*body.node_list)(j)).transpose()));
                    data.patch[static_cast<std::size_t>(p)] = box;
                }
            });
    });
}

void NarrowPhase::add_pair(const std::vector<NarrowPhaseBody>& bodies, const PrimitivePairRef& pair,
    double margin, double lookahead, double extra)
{
    // Grown by the margin and by how far the two bodies' nodes may move in the step.
    const double grow = margin + bodies[static_cast<std::size_t>(pair.body_a)].motion
        + bodies[static_cast<std::size_t>(pair.body_b)].motion;
    const Box3 region(pair.region.min().array() - grow, pair.region.max().array() + grow);
    if (region.isEmpty())
        return;
    // Between two bodies, a face of one primitive meets a face of the other only within that
    // one's patch, and a node finds a face only within its reach (the margin, plus `extra`
    // against a static body, its own speed's lookahead and the other body's motion): each
    // primitive's share of the region is what lies within that reach of the other's patch.
    const double reach = grow + extra
        + lookahead
            * std::max(m_bodies[static_cast<std::size_t>(pair.body_a)].fastest,
                m_bodies[static_cast<std::size_t>(pair.body_b)].fastest);
    const auto near = [&](int body, int primitive) {
        const Box3& patch
            = m_bodies[static_cast<std::size_t>(body)].patch[static_cast<std::size_t>(primitive)];
        return region.intersection(Box3(patch.min().array() - reach, patch.max().array() + reach));
    };
    const bool self = pair.body_a == pair.body_b;
    const Box3 share_a = self ? region : near(pair.body_b, pair.primitive_b);
    const Box3 share_b = self ? region : near(pair.body_a, pair.primitive_a);
    if (share_a.isEmpty() && share_b.isEmpty())
        return;
    if (!share_a.isEmpty())
        extend_region(pair.body_a, pair.primitive_a, share_a, self);
    if (!share_b.isEmpty())
        extend_region(pair.body_b, pair.primitive_b, share_b, self);
    BodyData& data_a = m_bodies[static_cast<std::size_t>(pair.body_a)];
    BodyData& data_b = m_bodies[static_cast<std::size_t>(pair.body_b)];
    add_once(data_a.partner_stamp, pair.body_b, m_run, data_a.partners);
    add_once(data_b.partner_stamp, pair.body_a, m_run, data_b.partners);
    if (self)
        data_a.self_pairs.push_back(pair_key(pair.primitive_a, pair.primitive_b));
}

void NarrowPhase::extend_region(int body, int primitive, const Box3& region, bool self)
{
    BodyData& data = m_bodies[static_cast<std::size_t>(body)];
    const std::size_t p = static_cast<std::size_t>(primitive);
    if (data.stamp[p] != m_run) {
        data.stamp[p] = m_run;
        data.region[p] = Box3();
        data.self_region[p] = Box3();
        data.active.push_back(primitive);
    }
    (self ? data.self_region : data.region)[p].extend(region);
}

void NarrowPhase::collect_active(const NarrowPhaseBody& body, BodyData& data) const
{
    data.box = Box3();
    data.node_kinds.clear();
    for (const int p : data.active) {
        const Box3& region = data.region[static_cast<std::size_t>(p)];
        const Box3& self_region = data.self_region[static_cast<std::size_t>(p)];
        for (int j = (*body.face_indptr)(p); j < (*body.face_indptr)(p + 1); ++j) {
            const int f = (*body.face_list)(j);
            int& stamp = data.face_stamp[static_cast<std::size_t>(f)];
            unsigned char& kinds = data.face_kinds[static_cast<std::size_t>(f)];
            if (stamp == m_run && kinds == (other_kind | self_kind))
                continue;
            const Box3 box = face_box(body, f);
            const unsigned char in = (boxes_overlap(box, region) ? other_kind : 0)
                | (boxes_overlap(box, self_region) ? self_kind : 0);
            if (in == 0)
                continue;
            if (stamp == m_run) {
                kinds |= in;
                continue;
            }
            stamp = m_run;
            kinds = in;
            data.grid.items.push_back({ box, f });
            data.box.extend(box);
        }
        if (body.is_static)
            continue;
        for (int j = (*body.node_indptr)(p); j < (*body.node_indptr)(p + 1); ++j) {
            const int node = (*body.node_list)(j);
            const Vec3 x = body.nodes->row(node).transpose();
            const unsigned char in
                = (region.contains(x) ? other_kind : 0) | (self_region.contains(x) ? self_kind : 0);
            if (in == 0)
                continue;
            data.nodes.push_back({ Box3(x, x), node });
            data.node_kinds.push_back(in);
        }
    }
}

void NarrowPhase::choose_sweep_axis()
{
    Box3 all;
    for (const BodyData& data : m_bodies)
        all.extend(data.box);
    m_axis = 0;
    if (!all.isEmpty())
        all.sizes().minCoeff(&m_axis);
}

void NarrowPhase::file_faces(const NarrowPhaseBody& body, BodyData& data, int axis)
{
    data.grid.build(axis);
    // Per position in the grid (in parallel: each position written by one task), its plane and
    // the corners' motion (see Reach); then, in order, the body's mean velocity and spread over
    // its active faces.
    const std::size_t n = data.grid.items.size();
    data.motion.assign(n, BodyData::FaceMotion {});
    data.geometry.resize(n);
    data.mean_velocity = Vec3::Zero();
    data.velocity_spread = 0.0;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, 512), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t k = r.begin(); k != r.end(); ++k)
                place_face(body, data, k);
        });
    if (body.velocities == nullptr || n == 0) {
        summarize_columns(
            data.grid, [&](std::size_t k) -> const BodyData::FaceMotion& { return data.motion[k]; },
            data.columns);
        return;
    }
    for (const BodyData::FaceMotion& motion : data.motion)
        data.mean_velocity += motion.mean;
    data.mean_velocity /= static_cast<double>(n);
    for (const BodyData::FaceMotion& motion : data.motion)
        data.velocity_spread = std::max(
            data.velocity_spread, (motion.mean - data.mean_velocity).norm() + motion.spread);
    summarize_columns(
        data.grid, [&](std::size_t k) -> const BodyData::FaceMotion& { return data.motion[k]; },
        data.columns);
}

void NarrowPhase::place_face(const NarrowPhaseBody& body, BodyData& data, std::size_t k)
{
    NarrowFace& g = data.geometry[k];
    const int f = data.grid.at(k).index;
    g.p0 = corner(body, f, 0);
    g.p1 = corner(body, f, 1);
    g.p2 = corner(body, f, 2);
    const Vec3 normal = (g.p1 - g.p0).cross(g.p2 - g.p0);
    const double length = normal.norm();
    g.degenerate = !(length > 0.0);
    g.unit = g.degenerate ? Vec3(Vec3::UnitY()) : Vec3(normal / length);
    g.normal_speed = 0.0;
    if (body.velocities == nullptr)
        return;
    BodyData::FaceMotion& motion = data.motion[k];
    std::array<Vec3, 3> v;
    g.normal_speed = -std::numeric_limits<double>::infinity();
    for (int c = 0; c < 3; ++c) {
        v[static_cast<std::size_t>(c)] = body.velocities->row((*body.faces)(f, c)).transpose();
        g.normal_speed = std::max(g.normal_speed, g.unit.dot(v[static_cast<std::size_t>(c)]));
        motion.speed = std::max(motion.speed, v[static_cast<std::size_t>(c)].norm());
    }
    motion.mean = (v[0] + v[1] + v[2]) / 3.0;
    for (const Vec3& corner_velocity : v)
        motion.spread = std::max(motion.spread, (corner_velocity - motion.mean).norm());
}

bool NarrowPhase::self_pair_allowed(int body, int face_a, int face_b, bool node_a) const
{
    const BodyData& data = m_bodies[static_cast<std::size_t>(body)];
    const auto colliding = [&](int pa, int pb) {
        return std::binary_search(data.self_pairs.begin(), data.self_pairs.end(), pair_key(pa, pb));
    };
    const VecXi& indptr = data.face_primitive_indptr;
    for (int j = indptr(face_b); j < indptr(face_b + 1); ++j) {
        const int pb = data.face_primitives(j);
        if (node_a) {
            if (colliding(data.node_primitive(face_a), pb))
                return true;
            continue;
        }
        for (int i = indptr(face_a); i < indptr(face_a + 1); ++i)
            if (colliding(data.face_primitives(i), pb))
                return true;
    }
    return false;
}

namespace {
    Vec3 node_velocity(const NarrowPhaseBody& body, int node)
    {
        return body.velocities != nullptr ? Vec3(body.velocities->row(node).transpose())
                                          : Vec3::Zero();
    }

    /// Whether triangles fa of a and fb of b share a corner (vertex index).
    bool share_corner(const NarrowPhaseBody& a, int fa, const NarrowPhaseBody& b, int fb)
    {
        bool shared = false;
        for (int u = 0; u < 3; ++u)
            for (int v = 0; v < 3; ++v)
                shared |= (*a.faces)(fa, u) == (*b.faces)(fb, v);
        return shared;
    }

    /// One node's search among the triangles of one partner body.
    struct NodeQuery {
        Vec3 x = Vec3::Zero(); ///< the node's position
        Vec3 velocity = Vec3::Zero(); ///< the node's velocity
        double margin = 0.0;
        double lookahead = 0.0;
        double near = 0.0; ///< the margin, plus the extra against a body that does not fall
        double reach = 0.0; ///< near, plus the node's and the other body's motion in the step
        bool same_body = false; ///< the triangles are of the node's own body
        bool stopping = true; ///< either body may stop (two bodies; not within one)
    };

    /// A triangle that takes the node: its closest point, signed distance and unit normal.
    struct FaceHit {
        PointTriangleClosest closest;
        double distance = 0.0; ///< signed: negative behind the triangle
        double plane = 0.0; ///< signed, from the triangle's plane (NodeCandidate::plane)
        Vec3 normal = Vec3::UnitY();
    };

    /// Whether the node is in front of the (non-degenerate) triangle's plane by the reach or
    /// more, or by more than it can close at its fastest approach to a corner: the
    /// stopping_approach of the node and the face's normal_speed (the fastest corner's; with a
    /// relative slack of 1e-12 for the rounding: the rejection must be sure).
    bool plane_out_of_reach(const NodeQuery& q, const NarrowFace& g)
    {
        const double plane = g.unit.dot(q.x - g.p0);
        if (plane >= q.reach)
            return true;
        if (plane >= q.near) {
            const double along = g.unit.dot(q.velocity);
            const double approach
                = NarrowPhase::stopping_approach(along, g.normal_speed, q.stopping)
                + 1e-12 * (std::abs(g.normal_speed) + std::abs(along));
            if (plane >= (1.0 + 1e-12) * (q.near + q.lookahead * approach))
                return true;
        }
        return false;
    }

    /// Whether a node behind the triangle (p0, p1, p2), `distance` from it, is too far: outside
    /// the triangle's box grown by the margin (or, within one body, not within the margin).
    bool behind_out_of_reach(
        const NodeQuery& q, const Vec3& p0, const Vec3& p1, const Vec3& p2, double distance)
    {
        // Within one body, only within the margin: a vertex behind a face of another part of
        // its own body may just be on the far side of it.
        if (q.same_body && distance >= q.margin)
            return true;
        const Vec3 lo = p0.cwiseMin(p1).cwiseMin(p2).array() - q.margin;
        const Vec3 hi = p0.cwiseMax(p1).cwiseMax(p2).array() + q.margin;
        return (q.x.array() < lo.array()).any() || (q.x.array() > hi.array()).any();
    }

    /// Whether a node in front of triangle f at `signed_distance` (beyond the margin) is further
    /// than it may close in the step on the closest point (stopping_approach).
    bool approach_out_of_reach(const NodeQuery& q, const NarrowPhaseBody& other, int f,
        const PointTriangleClosest& closest, const Vec3& unit, double signed_distance)
    {
        Vec3 v_point = Vec3::Zero();
        for (int c = 0; c < 3; ++c)
            v_point += closest.barycentric(c) * node_velocity(other, (*other.faces)(f, c));
        const double approach
            = NarrowPhase::stopping_approach(unit.dot(q.velocity), unit.dot(v_point), q.stopping);
        return signed_distance >= q.near + q.lookahead * approach;
    }

    /// Node `q` against triangle f of `other`: true, with `hit`, if the triangle takes it.
    bool node_face_hit(
        const NodeQuery& q, const NarrowPhaseBody& other, int f, const NarrowFace& g, FaceHit& hit)
    {
        const Vec3& p0 = g.p0;
        const Vec3& p1 = g.p1;
        const Vec3& p2 = g.p2;
        const Vec3& unit = g.unit;
        // In front of the triangle's plane by the reach or more, or by more than the node can
        // close at its fastest approach to a corner (the closest point's velocity lies between
        // the corners'): so is its closest point (which is at least as far), and the node is no
        // candidate.
        if (!g.degenerate && plane_out_of_reach(q, g))
            return false;
        const PointTriangleClosest closest = point_triangle_closest(q.x, p0, p1, p2);
        const double distance = std::sqrt(closest.squared_distance);
        const double signed_distance = unit.dot(q.x - closest.point) < 0.0 ? -distance : distance;
        // Behind: in the triangle's box grown by the margin only (a wider search would take in
        // nodes on the far side of a part thinner than the reach). In front: within the margin,
        // plus what the node may close in the step at its approach speed.
        if (signed_distance < 0.0) {
            if (behind_out_of_reach(q, p0, p1, p2, distance))
                return false;
        } else if (signed_distance >= q.reach) {
            return false;
        }
        if (signed_distance >= q.near
            && approach_out_of_reach(q, other, f, closest, unit, signed_distance))
            return false;
        hit.closest = closest;
        hit.distance = signed_distance;
        hit.plane = unit.dot(q.x - closest.point);
        hit.normal = unit;
        return true;
    }

    /// The bounds that let a node skip a face before the exact tests (node_face_hit). A face
    /// is rejected by node_face_hit when the distance from the node to its box exceeds both
    /// sqrt(3) margins (a node behind a face is taken only within its box grown by the margin on
    /// each axis) and near + lookahead x the approach speed to the closest point (a node in
    /// front), and that approach (stopping_approach) is at most the largest of |v_node -
    /// v_point|, |v_node| and |v_point| for a point of the face. Two bounds of that speed: the
    /// node's speed plus the face's fastest corner's, and the largest of the node's velocity
    /// relative to the face's mean corner velocity plus the corners' spread about it, the node's
    /// speed, and the mean's plus the spread (the point's velocity lies between the corners';
    /// without NodeQuery::stopping, the first of these alone).
    /// Either rejection changes nothing. Each bound has a relative slack of 1e-9, plus `slack`
    /// (m) against the rounding of the means.
    struct Reach {
        double hold = 0.0; ///< max(near, sqrt(3) margin)
        double most = 0.0; ///< the node's reach, and the bound over all the body's faces
        double own_speed = 0.0;
        double slack = 0.0;
    };

    /// The second bound above alone: through the node's velocity relative to the faces' mean
    /// velocity (or either alone), plus their spread about it.
    double relative_reach(
        const NodeQuery& q, const Reach& r, const Vec3& mean_velocity, double spread)
    {
        const double relative = (q.velocity - mean_velocity).norm() + spread;
        const double speed = q.stopping
            ? std::max({ relative, r.own_speed, mean_velocity.norm() + spread })
            : relative;
        return (1.0 + 1e-9) * (r.hold + q.lookahead * speed) + r.slack;
    }
    /// The farthest from a node that a face (or every face of a set) whose corners move as
    /// (mean velocity, fastest corner's speed, spread about the mean) can take it: the smaller
    /// of the two bounds above.
    double motion_reach(
        const NodeQuery& q, const Reach& r, const Vec3& mean_velocity, double speed, double spread)
    {
        return std::min((1.0 + 1e-9) * (r.hold + q.lookahead * (r.own_speed + speed)),
            relative_reach(q, r, mean_velocity, spread));
    }

    /// The squared distance from the node to a box, or -1 if it is further than `reach` on an
    /// axis.
    double squared_gap(const Vec3& x, const Box3& box, double reach)
    {
        double squared = 0.0;
        for (Index a = 0; a < 3; ++a) {
            const double gap = std::max({ box.min()[a] - x[a], x[a] - box.max()[a], 0.0 });
            if (gap > reach)
                return -1.0;
            squared += gap * gap;
        }
        return squared;
    }

    /// Whether a face is out of the node's reach: further than its motion_reach, or than
    /// r.most on an axis (the grid's own test, with which a node behind a face within the
    /// margin on each axis is kept). `beaten`: the squared distance of the best hit so far
    /// (infinite: none); a face whose box is further loses to it (its distance is at least that
    /// of its box) and is skipped too. The cheap tests first: one per face visited.
    bool face_out_of_reach(const NodeQuery& q, const Reach& r, const Box3& box,
        const Vec3& mean_velocity, double speed, double spread, double beaten)
    {
        const double squared = squared_gap(q.x, box, r.most);
        if (squared < 0.0 || squared > (1.0 + 1e-9) * beaten)
            return true;
        const double own = (1.0 + 1e-9) * (r.hold + q.lookahead * (r.own_speed + speed));
        if (squared > own * own)
            return true;
        const double relative = relative_reach(q, r, mean_velocity, spread);
        return squared > relative * relative;
    }

    /// How far on an axis a face of a set (a grid column: its box and motion) may be from the
    /// node, or -1 if the whole set is out of reach (as face_out_of_reach).
    double set_reach(const NodeQuery& q, const Reach& r, const Box3& box, const Vec3& mean_velocity,
        double speed, double spread, double beaten)
    {
        const double reach = motion_reach(q, r, mean_velocity, speed, spread);
        const double grow = std::min(r.most, reach);
        const double squared = squared_gap(q.x, box, grow);
        return squared < 0.0 || squared > (1.0 + 1e-9) * beaten || squared > reach * reach ? -1.0
                                                                                           : grow;
    }

    /// Whether a hit at `signed_distance` on triangle f of body bf loses to `best`: further
    /// (unsigned), or as far on a higher (body, face).
    bool loses_to(const NodeCandidate& best, double signed_distance, int bf, int f)
    {
        const double d = std::abs(signed_distance);
        const double d_best = std::abs(best.distance);
        return d > d_best
            || (d == d_best && std::make_pair(bf, f) > std::make_pair(best.other_body, best.face));
    }
} // namespace

template <class Visit> void NarrowPhase::in_chunks(std::size_t n, const Visit& visit)
{
    tbb::parallel_for(
        tbb::blocked_range<int>(0, work_chunks, 1), [&](const tbb::blocked_range<int>& chunks) {
            for (int c = chunks.begin(); c != chunks.end(); ++c) {
                Scratch& scratch = m_scratch[static_cast<std::size_t>(c)];
                for (std::size_t k = c * n / work_chunks; k != (c + 1) * n / work_chunks; ++k)
                    visit(scratch, k);
            }
        });
}

void NarrowPhase::clear_scratch()
{
    if (m_scratch.size() < static_cast<std::size_t>(work_chunks))
        m_scratch.resize(work_chunks);
    for (Scratch& scratch : m_scratch) {
        scratch.intersecting.clear();
        scratch.triangle_tests = 0;
        scratch.node_tests = 0;
        scratch.edge_tests = 0;
    }
}

void NarrowPhase::build_work_lists()
{
    m_work.clear();
    m_node_work.clear();
    for (std::size_t b = 0; b < m_bodies.size(); ++b) {
        for (std::size_t i = 0; i < m_bodies[b].grid.items.size(); ++i)
            m_work.push_back({ static_cast<int>(b), static_cast<int>(i) });
        for (std::size_t i = 0; i < m_bodies[b].nodes.size(); ++i)
            m_node_work.push_back({ static_cast<int>(b), static_cast<int>(i) });
    }
}

void NarrowPhase::test_triangle(
    const std::vector<NarrowPhaseBody>& bodies, Scratch& scratch, std::size_t k) const
{
    const int ba = m_work[k][0];
    const int position = m_work[k][1];
    const BodyData& data = m_bodies[static_cast<std::size_t>(ba)];
    const Item& item = data.grid.at(static_cast<std::size_t>(position));
    const int fa = item.index;
    const NarrowPhaseBody& a = bodies[static_cast<std::size_t>(ba)];
    const Vec3 a0 = corner(a, fa, 0);
    const Vec3 a1 = corner(a, fa, 1);
    const Vec3 a2 = corner(a, fa, 2);
    const auto test = [&](int bb, int fb) {
        const NarrowPhaseBody& b = bodies[static_cast<std::size_t>(bb)];
        ++scratch.triangle_tests;
        if (triangles_intersect(a0, a1, a2, corner(b, fb, 0), corner(b, fb, 1), corner(b, fb, 2)))
            scratch.intersecting.push_back(bb == ba
                    ? FacePair { ba, std::min(fa, fb), ba, std::max(fa, fb) }
                    : FacePair { ba, fa, bb, fb });
    };
    // Only against what the face's regions reach: other bodies, its own body.
    const unsigned char kinds = data.face_kinds[static_cast<std::size_t>(fa)];
    for (const int bb : data.partners) {
        if (bb < ba || (kinds & (bb == ba ? self_kind : other_kind)) == 0)
            continue;
        if (bb != ba) {
            m_bodies[static_cast<std::size_t>(bb)].grid.overlapping(
                item.box, 0.0, [&](int fb, int) { test(bb, fb); });
            continue;
        }
        // Within the body: the later positions that the face's primitives' self rows allow
        // (each pair once), or without rows, those with a later face that the searches allow.
        if (data.self_bits.empty()) {
            data.grid.overlapping(item.box, 0.0, [&](int fb, int) {
                if (fb > fa && self_pair_allowed(ba, fa, fb, false) && !share_corner(a, fa, a, fb))
                    test(ba, fb);
            });
            continue;
        }
        const auto words = [&](int w) { return face_row_word(data, fa, w); };
        data.grid.overlapping_after(item.box, position, words, [&](int fb, int) {
            if (!share_corner(a, fa, a, fb))
                test(ba, fb);
        });
    }
}

bool NarrowPhase::own_face_excluded(
    const NarrowPhaseBody& own, int body, int node, int face, bool allowed_known) const
{
    if (own.nodes_are_vertices
        && ((*own.faces)(face, 0) == node || (*own.faces)(face, 1) == node
            || (*own.faces)(face, 2) == node))
        return true;
    if (!allowed_known && !self_pair_allowed(body, node, face, true))
        return true;
    if (own.rest_near_indptr != nullptr) {
        const int* begin = own.rest_near_list->data() + (*own.rest_near_indptr)(node);
        const int* end = own.rest_near_list->data() + (*own.rest_near_indptr)(node + 1);
        if (std::binary_search(begin, end, face))
            return true;
    }
    return false;
}

bool NarrowPhase::nearest_triangle(const std::vector<NarrowPhaseBody>& bodies, double margin,
    double lookahead, double extra, Scratch& scratch, std::size_t k, NodeCandidate& best) const
{
    const int bn = m_node_work[k][0];
    const BodyData& data = m_bodies[static_cast<std::size_t>(bn)];
    const Item& item = data.nodes[static_cast<std::size_t>(m_node_work[k][1])];
    const NarrowPhaseBody& own = bodies[static_cast<std::size_t>(bn)];
    NodeQuery query;
    query.x = item.box.min();
    query.velocity = node_velocity(own, item.index);
    query.margin = margin;
    query.lookahead = lookahead;
    bool found = false;
    // Only against what the node's regions reach: other bodies, its own body.
    const unsigned char kinds = data.node_kinds[static_cast<std::size_t>(m_node_work[k][1])];
    for (const int bf : data.partners) {
        if ((kinds & (bf == bn ? self_kind : other_kind)) == 0)
            continue;
        const NarrowPhaseBody& other = bodies[static_cast<std::size_t>(bf)];
        // Within the margin (plus what gravity adds in a step against a body that does not
        // fall: both dynamic bodies fall alike), or within reach of the node's approach in the
        // step: at most its own speed and the other body's motion bound.
        query.near = margin + (own.is_static != other.is_static ? extra : 0.0);
        query.reach = query.near + lookahead * query.velocity.norm() + other.motion;
        query.same_body = bf == bn;
        // Within one body, the approach at the start velocities only: a part does not stop
        // while another goes on as two bodies do (docs/method.md, "Speculative contacts").
        query.stopping = !query.same_body;
        const BodyData& faces = m_bodies[static_cast<std::size_t>(bf)];
        // Only the faces that the node's velocity relative to the body's active faces (their
        // mean velocity, plus the spread about it) can reach: see Reach.
        // Behind a face of its own body, a node counts only within the margin (Euclidean:
        // behind_out_of_reach), so there the per-axis box test behind needs no sqrt(3).
        Reach r;
        r.hold = query.same_body ? query.near : std::max(query.near, std::sqrt(3.0) * margin);
        r.own_speed = query.velocity.norm();
        r.slack
            = 1e-9 * lookahead * (r.own_speed + faces.mean_velocity.norm() + faces.velocity_spread);
        r.most = std::min(
            query.reach, relative_reach(query, r, faces.mean_velocity, faces.velocity_spread));
        // Each column grows by the reach of its own faces' motion (a column's bounds hold for
        // each of its faces), and is skipped when it is out of that reach.
        const auto column_grow = [&](int c) {
            const BodyData::ColumnMotion& column = faces.columns[static_cast<std::size_t>(c)];
            const double beaten
                = found ? best.distance * best.distance : std::numeric_limits<double>::infinity();
            return set_reach(query, r, column.box, column.motion.mean, column.motion.speed,
                column.motion.spread, beaten);
        };
        // Within the body, only the faces that the node's primitive's self row allows (none
        // without a row), filtered with the boxes.
        const bool rows = bf == bn && !faces.self_bits.empty();
        const auto visit = [&](int f, int k) {
            const BodyData::FaceMotion& motion = faces.motion[static_cast<std::size_t>(k)];
            const double beaten
                = found ? best.distance * best.distance : std::numeric_limits<double>::infinity();
            if (face_out_of_reach(query, r, faces.grid.at(static_cast<std::size_t>(k)).box,
                    motion.mean, motion.speed, motion.spread, beaten))
                return;
            if (bf == bn && own_face_excluded(other, bn, item.index, f, rows))
                return;
            ++scratch.node_tests;
            FaceHit hit;
            if (!node_face_hit(query, other, f, faces.geometry[static_cast<std::size_t>(k)], hit))
                return;
            if (found && loses_to(best, hit.distance, bf, f))
                return;
            best.body = bn;
            best.node = item.index;
            best.other_body = bf;
            best.face = f;
            best.distance = hit.distance;
            best.plane = hit.plane;
            best.closest = hit.closest.point;
            best.barycentric = hit.closest.barycentric;
            best.normal = hit.normal;
            found = true;
        };
        if (!rows) {
            faces.grid.overlapping(item.box, r.most, column_grow, visit);
            continue;
        }
        const int primitive = faces.node_primitive(item.index);
        const int row = primitive < 0 ? -1 : faces.self_row[static_cast<std::size_t>(primitive)];
        if (row >= 0)
            faces.grid.overlapping_allowed(item.box, r.most, column_grow,
                faces.self_bits.data() + static_cast<std::size_t>(row) * faces.self_words, visit);
    }
    return found;
}

void NarrowPhase::merge_results()
{
    // In chunk order.
    m_intersecting.clear();
    m_triangle_tests = 0;
    m_node_tests = 0;
    m_edge_tests = 0;
    for (const Scratch& scratch : m_scratch) {
        m_intersecting.insert(
            m_intersecting.end(), scratch.intersecting.begin(), scratch.intersecting.end());
        m_triangle_tests += scratch.triangle_tests;
        m_node_tests += scratch.node_tests;
        m_edge_tests += scratch.edge_tests;
    }
    std::sort(m_intersecting.begin(), m_intersecting.end());
    m_candidates.clear();
    for (std::size_t k = 0; k < m_node_work.size(); ++k)
        if (m_node_found[k])
            m_candidates.push_back(m_node_best[k]);
    std::sort(m_candidates.begin(), m_candidates.end(),
        [](const NodeCandidate& x, const NodeCandidate& y) {
            return std::make_pair(x.body, x.node) < std::make_pair(y.body, y.node);
        });
    // The edge work list is in (body, filed face) order: sorted by (body, edge).
    m_edge_candidates.clear();
    for (std::size_t k = 0; k < m_edge_work.size(); ++k)
        if (m_edge_found[k])
            m_edge_candidates.push_back(m_edge_best[k]);
    std::sort(m_edge_candidates.begin(), m_edge_candidates.end(),
        [](const EdgeCandidate& x, const EdgeCandidate& y) {
            return std::make_pair(x.body, x.edge) < std::make_pair(y.body, y.edge);
        });
}

void NarrowPhase::run(const std::vector<NarrowPhaseBody>& bodies,
    const std::vector<PrimitivePairRef>& pairs, double margin, double lookahead, double extra)
{
    prepare(bodies);
    activate(bodies, pairs, margin, lookahead, extra);
    clear_scratch();
    build_work_lists();
    // Triangle pairs: each active triangle against the later bodies' active triangles (and its
    // own body's later ones, for self pairs) whose boxes overlap its box.
    if (m_triangle_pairs)
        in_chunks(m_work.size(),
            [&](Scratch& scratch, std::size_t k) { test_triangle(bodies, scratch, k); });
    // Nodes: against the triangles of every partner body whose box grown by the reach holds
    // them; the nearest within the reach (or behind) wins, ties to the lowest (body, face).
    m_node_best.resize(m_node_work.size());
    m_node_found.assign(m_node_work.size(), 0);
    in_chunks(m_node_work.size(), [&](Scratch& scratch, std::size_t k) {
        m_node_found[k]
            = nearest_triangle(bodies, margin, lookahead, extra, scratch, k, m_node_best[k]);
    });
    // Sharp edges: against the sharp edges of every partner body within their reach (the lower
    // body of two dynamic ones searches); the nearest wins, ties to the lowest (body, edge).
    m_edge_work.clear();
    if (m_edge_contacts)
        build_edge_work(bodies);
    m_edge_best.resize(m_edge_work.size());
    m_edge_found.assign(m_edge_work.size(), 0);
    in_chunks(m_edge_work.size(), [&](Scratch& scratch, std::size_t k) {
        m_edge_found[k]
            = nearest_edge(bodies, margin, lookahead, extra, scratch, k, m_edge_best[k]);
    });
    merge_results();
}

} // namespace mat
