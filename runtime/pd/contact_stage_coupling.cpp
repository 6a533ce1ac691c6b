// The contact stage as the contact solve's coupling (runtime/pd/contact.hpp, ContactCoupling;
// docs/method.md, "Contact"): W between the contacts that have been in a working set, and the
// positions of all contacts through each body's summed response.

#include <algorithm>
#include <array>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "runtime/pd/contact_stage.hpp"
#include "runtime/pd/solver.hpp"

namespace mat {

double ContactStage::coupling_between(Index c, Index d)
{
    const Record& record_c = m_records[static_cast<std::size_t>(c)];
    Record& record_d = m_records[static_cast<std::size_t>(d)];
    double sum = 0.0;
    for (int sd = 0; sd < record_d.num_sides; ++sd) {
        Side& side_d = record_d.sides[static_cast<std::size_t>(sd)];
        for (int sc = 0; sc < record_c.num_sides; ++sc) {
            const Side& side_c = record_c.sides[static_cast<std::size_t>(sc)];
            if (side_c.body != side_d.body)
                continue;
            if (m_data[static_cast<std::size_t>(side_c.body)].nodal) {
                sum += nodal_coupling(side_c, side_d);
                continue;
            }
            double scale = 1.0;
            const double* z = response(side_d, scale);
            sum += scale * side_apply(side_c, z);
        }
    }
    return sum;
}

namespace {

    /// Grows `block`'s room to at least rows x cols, keeping its used top-left corner.
    void reserve_block(
        HugePageBlock& block, Index used_rows, Index used_cols, Index rows, Index cols)
    {
        if (rows <= block.rows() && cols <= block.cols())
            return;
        HugePageBlock grown(std::max(rows, 2 * block.rows()), std::max(cols, 2 * block.cols()));
        for (Index c = 0; c < used_cols; ++c)
            std::copy(block.col(c), block.col(c) + used_rows, grown.col(c));
        block = std::move(grown);
    }

} // namespace

namespace {

    /// The smallest share of a parallel loop, in W entries or contact points (about 20 to
    /// 60 ns each): a parallel loop costs a wake-up of the other threads, which on a virtual
    /// machine can cost more than a few dozen such items (docs/method.md, "Pages and
    /// wake-ups").
    constexpr Index entry_grain = 256;

    /// f(begin, end) over [0, n) in blocks of at least `grain`, in parallel when there are two
    /// of them or more (as for_each_index).
    template <class F> void for_each_block(Index n, const F& f, Index grain = entry_grain)
    {
        if (n < 2 * grain) {
            f(Index { 0 }, n);
            return;
        }
        tbb::parallel_for(tbb::blocked_range<Index>(0, n, grain),
            [&](const tbb::blocked_range<Index>& range) { f(range.begin(), range.end()); });
    }

    /// f(i) for i in [0, n), in parallel when there are two blocks of `grain` or more: each i
    /// writes only its own results, so they do not depend on the thread count.
    template <class F> void for_each_index(Index n, const F& f, Index grain = entry_grain)
    {
        if (n < 2 * grain) {
            for (Index i = 0; i < n; ++i)
                f(i);
            return;
        }
        tbb::parallel_for(
            tbb::blocked_range<Index>(0, n, grain), [&](const tbb::blocked_range<Index>& range) {
                for (Index i = range.begin(); i != range.end(); ++i)
                    f(i);
            });
    }

    /// A sparse direction's product with a dense response (ContactStage::side_apply), to be
    /// taken several at a time.
    struct SparseDot {
        const int* index = nullptr;
        const double* value = nullptr;
        int count = 0;
        const double* z = nullptr;
        double result = 0.0;
    };

    /// Each dot's sum, in its own order (the same as side_apply's, so the same bits), four
    /// chains at a time: a dot is a chain of dependent multiply-adds, and four interleaved let
    /// their latencies overlap (the loads of the gathered entries still bound them).
    void sparse_dots(SparseDot* dots, int n)
    {
        int d = 0;
        for (; d + 4 <= n; d += 4) {
            SparseDot& a = dots[d];
            SparseDot& b = dots[d + 1];
            SparseDot& c = dots[d + 2];
            SparseDot& e = dots[d + 3];
            const int shared = std::min(std::min(a.count, b.count), std::min(c.count, e.count));
            double sa = 0.0, sb = 0.0, sc = 0.0, se = 0.0;
            for (int i = 0; i < shared; ++i) {
                sa += a.value[i] * a.z[a.index[i]];
                sb += b.value[i] * b.z[b.index[i]];
                sc += c.value[i] * c.z[c.index[i]];
                se += e.value[i] * e.z[e.index[i]];
            }
            for (int i = shared; i < a.count; ++i)
                sa += a.value[i] * a.z[a.index[i]];
            for (int i = shared; i < b.count; ++i)
                sb += b.value[i] * b.z[b.index[i]];
            for (int i = shared; i < c.count; ++i)
                sc += c.value[i] * c.z[c.index[i]];
            for (int i = shared; i < e.count; ++i)
                se += e.value[i] * e.z[e.index[i]];
            a.result = sa;
            b.result = sb;
            c.result = sc;
            e.result = se;
        }
        for (; d < n; ++d) {
            double sum = 0.0;
            for (int i = 0; i < dots[d].count; ++i)
                sum += dots[d].value[i] * dots[d].z[dots[d].index[i]];
            dots[d].result = sum;
        }
    }

} // namespace

void ContactStage::column_entries(
    const Index* contacts, const ColumnSides* const* columns, int count, double* out) const
{
    // Each entry's products (at most two sides of the row's contact by two of the column's),
    // then each entry summed over them, column sides outer, row sides inner.
    constexpr int block = 8;
    std::array<SparseDot, 4 * block> dots;
    std::array<double, 4 * block> scales {};
    std::array<int, block + 1> first {};
    for (int begin = 0; begin < count; begin += block) {
        const int end = std::min(count, begin + block);
        int n = 0;
        for (int e = begin; e < end; ++e) {
            first[static_cast<std::size_t>(e - begin)] = n;
            const Record& record_c = m_records[static_cast<std::size_t>(contacts[e])];
            const ColumnSides& column = *columns[e];
            for (int sd = 0; sd < column.count; ++sd)
                for (int sc = 0; sc < record_c.num_sides; ++sc) {
                    const Side& side_c = record_c.sides[static_cast<std::size_t>(sc)];
                    if (side_c.body != column.body[static_cast<std::size_t>(sd)])
                        continue;
                    SparseDot& dot = dots[static_cast<std::size_t>(n)];
                    if (m_data[static_cast<std::size_t>(side_c.body)].nodal) {
                        dot.index = m_term_node.data() + side_c.first;
                        dot.value = m_term_weight.data() + side_c.first;
                        dot.count = side_c.count;
                    } else {
                        dot.index = m_dir_index.data() + side_c.dir_first;
                        dot.value = m_dir_value.data() + side_c.dir_first;
                        dot.count = side_c.dir_count;
                    }
                    dot.z = column.response[static_cast<std::size_t>(sd)];
                    scales[static_cast<std::size_t>(n++)]
                        = column.scale[static_cast<std::size_t>(sd)];
                }
        }
        first[static_cast<std::size_t>(end - begin)] = n;
        sparse_dots(dots.data(), n);
        for (int e = begin; e < end; ++e) {
            double sum = 0.0;
            for (int k = first[static_cast<std::size_t>(e - begin)];
                 k < first[static_cast<std::size_t>(e - begin + 1)]; ++k)
                sum += scales[static_cast<std::size_t>(k)]
                    * dots[static_cast<std::size_t>(k)].result;
            out[e] = sum;
        }
    }
}

// Neighbouring faces share their corners' nodes: each node's position is taken once (in
// parallel over the nodes), then each face's corners from them.
void ContactStage::turn_planes()
{
    ++m_turn_stamp;
    for (BodyData& data : m_data)
        data.turn_nodes.clear();
    for (const Index a : m_joined) {
        const Record& record = m_records[static_cast<std::size_t>(a)];
        if (record.face < 0)
            continue;
        BodyData& data = m_data[static_cast<std::size_t>(record.face_body)];
        if (data.node_positions.rows() == 0) {
            const Index nodes
                = m_solvers[static_cast<std::size_t>(record.face_body)]->model().num_nodes();
            data.node_positions.resize(nodes, 3);
            data.node_stamp.assign(static_cast<std::size_t>(nodes), 0);
        }
        for (int t = record.face; t < record.face + 3 * BodyContacts::face_corner_terms; ++t) {
            const int node = m_face_node[static_cast<std::size_t>(t)];
            if (m_face_weight[static_cast<std::size_t>(t)] != 0.0
                && data.node_stamp[static_cast<std::size_t>(node)] != m_turn_stamp) {
                data.node_stamp[static_cast<std::size_t>(node)] = m_turn_stamp;
                data.turn_nodes.push_back(node);
            }
        }
    }
    for (std::size_t b = 0; b < m_data.size(); ++b) {
        BodyData& data = m_data[b];
        if (data.turn_nodes.empty())
            continue;
        const ContactResponse& step = m_solvers[b]->contact_response();
        for_each_index(static_cast<Index>(data.turn_nodes.size()), [&](Index i) {
            const int node = data.turn_nodes[static_cast<std::size_t>(i)];
            data.node_positions.row(node) = step.node_position(node).transpose();
        });
    }
    for_each_index(static_cast<Index>(m_joined.size()), [&](Index j) {
        const Index a = m_joined[static_cast<std::size_t>(j)];
        const Record& record = m_records[static_cast<std::size_t>(a)];
        if (record.face < 0)
            return;
        const MatX3& positions = m_data[static_cast<std::size_t>(record.face_body)].node_positions;
        std::array<Vec3, 3> corner;
        int t = record.face;
        for (Vec3& point : corner) {
            point.setZero();
            for (int k = 0; k < BodyContacts::face_corner_terms; ++k, ++t) {
                const double w = m_face_weight[static_cast<std::size_t>(t)];
                if (w != 0.0)
                    point
                        += w * positions.row(m_face_node[static_cast<std::size_t>(t)]).transpose();
            }
        }
        const Vec3 normal = (corner[1] - corner[0]).cross(corner[2] - corner[0]);
        const double length = normal.norm();
        if (length > 0.0)
            m_planes[static_cast<std::size_t>(m_pairs[static_cast<std::size_t>(a)].plane)].normal
                = normal / length;
    });
}

// A new row: W between c and each contact with a column (their responses kept by column()).
int ContactStage::cover(Index c)
{
    int& row = m_row_of[static_cast<std::size_t>(c)];
    if (row >= 0)
        return row;
    const Index rows = static_cast<Index>(m_rows.size());
    const Index cols = static_cast<Index>(m_cols.size());
    reserve_block(m_columns, rows, cols, std::max<Index>(rows + 1, 64), std::max<Index>(cols, 16));
    for_each_block(cols, [&](Index begin, Index end) {
        std::array<Index, 64> contact;
        std::array<const ColumnSides*, 64> sides {};
        std::array<double, 64> entry {};
        contact.fill(c);
        for (Index p = begin; p < end; p += 64) {
            const int n = static_cast<int>(std::min<Index>(64, end - p));
            for (int k = 0; k < n; ++k)
                sides[static_cast<std::size_t>(k)]
                    = &m_column_sides[static_cast<std::size_t>(p + k)];
            column_entries(contact.data(), sides.data(), n, entry.data());
            for (int k = 0; k < n; ++k)
                m_columns(rows, p + k) = entry[static_cast<std::size_t>(k)];
        }
    });
    ensure_diagonal(c);
    pack_row(c);
    m_rows.push_back(c);
    row = static_cast<int>(rows);
    return row;
}

void ContactStage::pack_row(Index c)
{
    const Record& record = m_records[static_cast<std::size_t>(c)];
    RowSides row;
    row.num_sides = record.num_sides;
    for (int s = 0; s < record.num_sides; ++s) {
        const Side& side = record.sides[static_cast<std::size_t>(s)];
        const bool nodal = m_data[static_cast<std::size_t>(side.body)].nodal;
        const int first = nodal ? side.first : side.dir_first;
        const int count = nodal ? side.count : side.dir_count;
        const int* index = nodal ? m_term_node.data() : m_dir_index.data();
        const double* value = nodal ? m_term_weight.data() : m_dir_value.data();
        row.body[static_cast<std::size_t>(s)] = side.body;
        row.count[static_cast<std::size_t>(s)] = count;
        row.first[static_cast<std::size_t>(s)] = static_cast<int>(m_row_index.size());
        m_row_index.insert(m_row_index.end(), index + first, index + first + count);
        m_row_value.insert(m_row_value.end(), value + first, value + first + count);
    }
    m_row_sides.push_back(row);
}

void ContactStage::column_rows(const ColumnSides& column, Index begin, Index end, double* out) const
{
    // column_entries' sums: per entry, column sides outer and row sides inner, each product a
    // chain in its terms' order, added to the entry in that order (the same bits).
    for (Index r = begin; r < end; ++r) {
        const RowSides& row = m_row_sides[static_cast<std::size_t>(r)];
        double sum = 0.0;
        for (int sd = 0; sd < column.count; ++sd) {
            const int body = column.body[static_cast<std::size_t>(sd)];
            const double* z = column.response[static_cast<std::size_t>(sd)];
            for (int sc = 0; sc < row.num_sides; ++sc) {
                if (row.body[static_cast<std::size_t>(sc)] != body)
                    continue;
                const int* index = m_row_index.data() + row.first[static_cast<std::size_t>(sc)];
                const double* value = m_row_value.data() + row.first[static_cast<std::size_t>(sc)];
                const int count = row.count[static_cast<std::size_t>(sc)];
                double dot = 0.0;
                for (int i = 0; i < count; ++i)
                    dot += value[i] * z[index[i]];
                sum += column.scale[static_cast<std::size_t>(sd)] * dot;
            }
        }
        out[r - begin] = sum;
    }
}

// A new column: W between each covered contact and d (J_c D_b z_d over d's sides).
const double* ContactStage::column(Index d)
{
    int& col = m_column_of[static_cast<std::size_t>(d)];
    if (col < 0) {
        const Index rows = static_cast<Index>(m_rows.size());
        const Index cols = static_cast<Index>(m_cols.size());
        reserve_block(
            m_columns, rows, cols, std::max<Index>(rows, 64), std::max<Index>(cols + 1, 16));
        // d's responses (computed here if they are not yet: not in parallel), kept for the rows
        // covered later.
        ColumnSides sides;
        Record& record_d = m_records[static_cast<std::size_t>(d)];
        sides.count = record_d.num_sides;
        for (int sd = 0; sd < record_d.num_sides; ++sd) {
            Side& side_d = record_d.sides[static_cast<std::size_t>(sd)];
            double scale = 1.0;
            sides.response[static_cast<std::size_t>(sd)]
                = m_data[static_cast<std::size_t>(side_d.body)].nodal ? nodal(side_d, scale)
                                                                      : response(side_d, scale);
            sides.scale[static_cast<std::size_t>(sd)] = scale;
            sides.body[static_cast<std::size_t>(sd)] = side_d.body;
        }
        for_each_block(rows, [&](Index begin, Index end) {
            column_rows(sides, begin, end, &m_columns(begin, cols));
        });
        m_cols.push_back(d);
        m_column_sides.push_back(sides);
        col = static_cast<int>(cols);
    }
    return m_columns.col(col);
}

void ContactStage::ensure_diagonal(Index c)
{
    char& known = m_diagonal_known[static_cast<std::size_t>(c)];
    if (known)
        return;
    m_diagonal(c) = coupling_between(c, c);
    known = 1;
    m_joined.push_back(c);
}

// A change of force costs an update of W's column over the working set (three per working
// contact, and the column's entries when it first pushes), or of its sides' bodies' node
// displacements (three per node of each): the second where the working set is larger than
// ContactSettings::through_bodies times the latter. Only where every side is on a nodal body
// (a full-space body's frames stay the same bits). Both are the same Gauss-Seidel sweeps; only
// the rounding of the points differs (docs/method.md, "Sweeps through the bodies").
bool ContactStage::sweep_through_bodies(const std::vector<Index>& working)
{
    Index widest = 0; // the most node rows a change of force updates through the bodies
    for (const Index c : working) {
        const Record& record = m_records[static_cast<std::size_t>(c)];
        Index rows = 0;
        for (int s = 0; s < record.num_sides; ++s) {
            const int body = record.sides[static_cast<std::size_t>(s)].body;
            if (!m_data[static_cast<std::size_t>(body)].nodal)
                return false;
            rows += m_solvers[static_cast<std::size_t>(body)]->model().num_nodes();
        }
        widest = std::max(widest, rows);
    }
    if (!(static_cast<double>(working.size())
            > m_settings.through_bodies * static_cast<double>(widest)))
        return false;
    for (const Index c : working)
        ensure_diagonal(c);
    for (std::size_t b = 0; b < m_data.size(); ++b)
        if (m_solvers[b] != nullptr && m_data[b].nodal)
            m_data[b].swept.setZero(m_solvers[b]->model().num_nodes(), 3);
    return true;
}

Vec3 ContactStage::moved(Index c) const
{
    const Record& record = m_records[static_cast<std::size_t>(c)];
    Vec3 x = Vec3::Zero();
    for (int s = 0; s < record.num_sides; ++s) {
        const Side& side = record.sides[static_cast<std::size_t>(s)];
        const MatX& swept = m_data[static_cast<std::size_t>(side.body)].swept;
        const Index nodes = swept.rows();
        for (int t = side.first; t < side.first + side.count; ++t) {
            const double* row = swept.data() + m_term_node[static_cast<std::size_t>(t)];
            x += m_term_weight[static_cast<std::size_t>(t)]
                * Vec3(row[0], row[nodes], row[2 * nodes]);
        }
    }
    return x;
}

void ContactStage::push(Index c, const Vec3& delta)
{
    Record& record = m_records[static_cast<std::size_t>(c)];
    for (int s = 0; s < record.num_sides; ++s) {
        Side& side = record.sides[static_cast<std::size_t>(s)];
        MatX& swept = m_data[static_cast<std::size_t>(side.body)].swept;
        double scale = 1.0;
        const Eigen::Map<const VecX> response(nodal(side, scale), swept.rows());
        swept.noalias() += response * (scale * delta).transpose();
    }
}

// Marks instead of a sort: one pass over the directions and one over each body's response rows.
void ContactStage::find_read_rows()
{
    for (std::size_t b = 0; b < m_data.size(); ++b) {
        m_data[b].read_rows.clear();
        if (m_solvers[b] != nullptr)
            m_data[b].read_mark.assign(
                static_cast<std::size_t>(m_solvers[b]->contact_response().response_size()), 0);
    }
    for (const Record& record : m_records)
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            std::vector<char>& mark = m_data[static_cast<std::size_t>(side.body)].read_mark;
            for (int i = side.dir_first; i < side.dir_first + side.dir_count; ++i)
                mark[static_cast<std::size_t>(m_dir_index[static_cast<std::size_t>(i)])] = 1;
        }
    for (std::size_t b = 0; b < m_data.size(); ++b) {
        if (m_solvers[b] == nullptr || m_data[b].nodal)
            continue; // a nodal body's points are taken from all of its nodes
        BodyData& data = m_data[b];
        const Index size = static_cast<Index>(data.read_mark.size());
        Index count = 0;
        for (const char mark : data.read_mark)
            count += mark;
        // Reading most rows: sum them all (contiguous).
        if (2 * count > size)
            continue;
        for (Index r = 0; r < size; ++r)
            if (data.read_mark[static_cast<std::size_t>(r)])
                data.read_rows.push_back(static_cast<int>(r));
    }
}

void ContactStage::sum_responses(const Eigen::Ref<const MatX3>& forces, bool all_rows)
{
    for (std::size_t b = 0; b < m_data.size(); ++b) {
        if (m_solvers[b] == nullptr || m_data[b].summed)
            continue;
        BodyData& data = m_data[b];
        const Index size = m_solvers[b]->contact_response().response_size();
        if (data.displacement.rows() != size)
            data.displacement.resize(size, 3);
        if (all_rows || data.read_rows.empty())
            data.displacement.setZero();
        else
            for (const int r : data.read_rows)
                data.displacement.row(r).setZero();
    }
    // The pushing sides' responses (computed here if they are not yet: not in parallel) and
    // forces, then each body's sum over its own, in parallel over the bodies (in contact order
    // within a body, whatever the thread count).
    const Index m = static_cast<Index>(m_records.size());
    for (BodyData& data : m_data)
        data.pushes.clear();
    for (Index a = 0; a < m; ++a) {
        if (!(forces.row(a).squaredNorm() > 0.0))
            continue;
        Record& record = m_records[static_cast<std::size_t>(a)];
        for (int s = 0; s < record.num_sides; ++s) {
            Side& side = record.sides[static_cast<std::size_t>(s)];
            if (m_data[static_cast<std::size_t>(side.body)].summed)
                continue;
            double scale = 1.0;
            const double* z = response(side, scale);
            m_data[static_cast<std::size_t>(side.body)].pushes.push_back(
                { z, scale * forces.row(a) });
        }
    }
    // In parallel over the bodies where the sums are worth a wake-up of the other threads
    // (for_each_index; a push costs 3 x the response size multiply-adds).
    Index work = 0;
    for (std::size_t b = 0; b < m_data.size(); ++b)
        if (m_solvers[b] != nullptr)
            work += static_cast<Index>(m_data[b].pushes.size())
                * m_solvers[b]->contact_response().response_size();
    const Index bodies = static_cast<Index>(m_data.size());
    for_each_index(
        bodies,
        [&](Index b) {
            BodyData& data = m_data[static_cast<std::size_t>(b)];
            if (m_solvers[static_cast<std::size_t>(b)] == nullptr || data.summed)
                return;
            const Index size = data.displacement.rows();
            if (all_rows || data.read_rows.empty()) {
                // Column by column (three contiguous updates per push), then into the rows.
                data.summing.setZero(size, 3);
                for (const BodyData::Push& push : data.pushes) {
                    const Eigen::Map<const VecX> z(push.response, size);
                    data.summing.noalias() += z * push.force;
                }
                data.displacement = data.summing;
                return;
            }
            for (const BodyData::Push& push : data.pushes) {
                const Eigen::Map<const VecX> z(push.response, size);
                for (const int r : data.read_rows)
                    data.displacement.row(r) += z(r) * push.force;
            }
        },
        work >= 256 * entry_grain ? 1 : bodies);
}

// x_c = x_free_c + sum over c's sides of J_cb (sum_d z_d f_d^T): the same as W f, without W.
// The free positions are those of the bodies' kept solutions u, so x_c is taken in one pass as
// the point of c's sides at u + sum_d z_d f_d^T (`free` is not read; docs/method.md, "W is
// never formed whole").
void ContactStage::displace(const Eigen::Ref<const MatX3>& /*free*/,
    const Eigen::Ref<const MatX3>& forces, const std::vector<char>* keep,
    Eigen::Ref<MatX3> positions)
{
    sum_responses(forces, false);
    for (BodyData& data : m_data)
        data.summed = false; // the sweeps change the forces
    // Each body's displaced solution, in place of its displacement, over the rows read; a
    // nodal body's node positions there.
    for (std::size_t b = 0; b < m_data.size(); ++b) {
        if (m_solvers[b] == nullptr)
            continue;
        BodyData& data = m_data[b];
        if (data.nodal) {
            const Index nodes = m_solvers[b]->model().num_nodes();
            if (data.displaced.rows() != nodes)
                data.displaced.resize(nodes, 3);
            m_solvers[b]->contact_response().displaced_positions(data.displacement, data.displaced);
            continue;
        }
        const ContactResponse::Rows u = m_solvers[b]->contact_response().solution_rows();
        const auto add_row = [&](Index r) {
            for (int j = 0; j < 3; ++j)
                data.displacement(r, j) += u.data[r * u.row_stride + j * u.column_stride];
        };
        if (data.read_rows.empty())
            for (Index r = 0; r < data.displacement.rows(); ++r)
                add_row(r);
        else
            for (const int r : data.read_rows)
                add_row(r);
    }
    const Index m = static_cast<Index>(m_records.size());
    for_each_index(m, [&](Index c) {
        if (keep != nullptr && (*keep)[static_cast<std::size_t>(c)])
            return;
        const Record& record = m_records[static_cast<std::size_t>(c)];
        Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            const BodyData& data = m_data[static_cast<std::size_t>(side.body)];
            if (data.nodal) {
                for (int k = side.first; k < side.first + side.count; ++k)
                    x += m_term_weight[static_cast<std::size_t>(k)]
                        * data.displaced.row(m_term_node[static_cast<std::size_t>(k)]);
                continue;
            }
            const MatX3& displaced = data.displacement;
            Eigen::RowVector3d point = side.offset.transpose();
            for (int i = side.dir_first; i < side.dir_first + side.dir_count; ++i)
                point += m_dir_value[static_cast<std::size_t>(i)]
                    * displaced.row(m_dir_index[static_cast<std::size_t>(i)]);
            x += point;
        }
        positions.row(c) = x;
    });
}

} // namespace mat
