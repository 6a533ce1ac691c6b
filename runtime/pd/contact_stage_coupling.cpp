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
    const Record& record_d = m_records[static_cast<std::size_t>(d)];
    double sum = 0.0;
    for (int sd = 0; sd < record_d.num_sides; ++sd) {
        const Side& side_d = record_d.sides[static_cast<std::size_t>(sd)];
        for (int sc = 0; sc < record_c.num_sides; ++sc) {
            const Side& side_c = record_c.sides[static_cast<std::size_t>(sc)];
            if (side_c.body != side_d.body)
                continue;
            double scale = 1.0;
            const auto z = response(side_d, scale);
            sum += scale * side_apply(side_c, z.data());
        }
    }
    return sum;
}

namespace {

    /// Grows `block`'s storage to at least rows x cols, keeping its used top-left corner.
    void reserve_block(MatX& block, Index used_rows, Index used_cols, Index rows, Index cols)
    {
        if (rows <= block.rows() && cols <= block.cols())
            return;
        MatX grown(std::max(rows, 2 * block.rows()), std::max(cols, 2 * block.cols()));
        grown.topLeftCorner(used_rows, used_cols) = block.topLeftCorner(used_rows, used_cols);
        block.swap(grown);
    }

} // namespace

namespace {

    /// f(i) for i in [0, n), in parallel when n is large enough to pay for it: each i writes
    /// only its own results, so they do not depend on the thread count.
    template <class F> void for_each_index(Index n, const F& f, Index grain = 64)
    {
        if (n <= grain) {
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

} // namespace

void ContactStage::compute_free_positions()
{
    for_each_index(static_cast<Index>(m_records.size()), [&](Index a) {
        const Record& record = m_records[static_cast<std::size_t>(a)];
        Vec3 x = Vec3::Zero();
        for (int s = 0; s < record.num_sides; ++s)
            x += side_position(record.sides[static_cast<std::size_t>(s)]);
        m_free.row(a) = x.transpose();
    });
}

void ContactStage::turn_planes()
{
    for_each_index(static_cast<Index>(m_rows.size()), [&](Index row) {
        const Index a = m_rows[static_cast<std::size_t>(row)];
        const Record& record = m_records[static_cast<std::size_t>(a)];
        if (record.face < 0)
            return;
        const ContactResponse& step
            = m_solvers[static_cast<std::size_t>(record.face_body)]->contact_response();
        std::array<Vec3, 3> corner;
        int t = record.face;
        for (Vec3& point : corner) {
            point.setZero();
            for (int k = 0; k < BodyContacts::face_corner_terms; ++k, ++t) {
                const double w = m_face_weight[static_cast<std::size_t>(t)];
                if (w != 0.0)
                    point += w * step.node_position(m_face_node[static_cast<std::size_t>(t)]);
            }
        }
        const Vec3 normal = (corner[1] - corner[0]).cross(corner[2] - corner[0]);
        const double length = normal.norm();
        if (length > 0.0)
            m_planes[static_cast<std::size_t>(m_pairs[static_cast<std::size_t>(a)].plane)].normal
                = normal / length;
    });
}

double ContactStage::column_entry(Index c, const ColumnSides& column) const
{
    const Record& record_c = m_records[static_cast<std::size_t>(c)];
    double sum = 0.0;
    for (int sd = 0; sd < column.count; ++sd)
        for (int sc = 0; sc < record_c.num_sides; ++sc) {
            const Side& side_c = record_c.sides[static_cast<std::size_t>(sc)];
            if (side_c.body == column.body[static_cast<std::size_t>(sd)])
                sum += column.scale[static_cast<std::size_t>(sd)]
                    * side_apply(side_c, column.response[static_cast<std::size_t>(sd)]);
        }
    return sum;
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
    for_each_index(cols, [&](Index p) {
        m_columns(rows, p) = column_entry(c, m_column_sides[static_cast<std::size_t>(p)]);
    });
    m_diagonal(c) = coupling_between(c, c);
    m_rows.push_back(c);
    row = static_cast<int>(rows);
    return row;
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
        const Record& record_d = m_records[static_cast<std::size_t>(d)];
        sides.count = record_d.num_sides;
        for (int sd = 0; sd < record_d.num_sides; ++sd) {
            const Side& side_d = record_d.sides[static_cast<std::size_t>(sd)];
            double scale = 1.0;
            sides.response[static_cast<std::size_t>(sd)] = response(side_d, scale).data();
            sides.scale[static_cast<std::size_t>(sd)] = scale;
            sides.body[static_cast<std::size_t>(sd)] = side_d.body;
        }
        for_each_index(rows, [&](Index r) {
            m_columns(r, cols) = column_entry(m_rows[static_cast<std::size_t>(r)], sides);
        });
        m_cols.push_back(d);
        m_column_sides.push_back(sides);
        col = static_cast<int>(cols);
    }
    return m_columns.col(col).data();
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
        if (m_solvers[b] == nullptr)
            continue;
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
        if (m_solvers[b] == nullptr)
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
        const Record& record = m_records[static_cast<std::size_t>(a)];
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            double scale = 1.0;
            const double* z = response(side, scale).data();
            m_data[static_cast<std::size_t>(side.body)].pushes.push_back(
                { z, scale * forces.row(a) });
        }
    }
    for_each_index(
        static_cast<Index>(m_data.size()),
        [&](Index b) {
            BodyData& data = m_data[static_cast<std::size_t>(b)];
            if (m_solvers[static_cast<std::size_t>(b)] == nullptr)
                return;
            const Index size = data.displacement.rows();
            for (const BodyData::Push& push : data.pushes) {
                const Eigen::Map<const VecX> z(push.response, size);
                if (all_rows || data.read_rows.empty())
                    data.displacement.noalias() += z * push.force;
                else
                    for (const int r : data.read_rows)
                        data.displacement.row(r) += z(r) * push.force;
            }
        },
        1);
}

// x_c = x_free_c + sum over c's sides of J_cb (sum_d z_d f_d^T): the same as W f, without W.
void ContactStage::displace(const Eigen::Ref<const MatX3>& free,
    const Eigen::Ref<const MatX3>& forces, const std::vector<char>* keep,
    Eigen::Ref<MatX3> positions)
{
    sum_responses(forces, false);
    const Index m = static_cast<Index>(m_records.size());
    for_each_index(m, [&](Index c) {
        if (keep != nullptr && (*keep)[static_cast<std::size_t>(c)])
            return;
        const Record& record = m_records[static_cast<std::size_t>(c)];
        Eigen::RowVector3d x = free.row(c);
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            const MatX3& displacement = m_data[static_cast<std::size_t>(side.body)].displacement;
            for (int i = side.dir_first; i < side.dir_first + side.dir_count; ++i)
                x += m_dir_value[static_cast<std::size_t>(i)]
                    * displacement.row(m_dir_index[static_cast<std::size_t>(i)]);
        }
        positions.row(c) = x;
    });
}

} // namespace mat
