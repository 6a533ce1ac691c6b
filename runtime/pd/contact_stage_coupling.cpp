// The contact stage as the contact solve's coupling (runtime/pd/contact.hpp, ContactCoupling;
// docs/method.md, "Contact"): W between the contacts that have been in a working set, and the
// positions of all contacts through each body's summed response.

#include <algorithm>

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
            sum += scale * side_apply(side_c, z);
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

// A new row: W between c and each contact with a column.
int ContactStage::cover(Index c)
{
    int& row = m_row_of[static_cast<std::size_t>(c)];
    if (row >= 0)
        return row;
    const Index rows = static_cast<Index>(m_rows.size());
    const Index cols = static_cast<Index>(m_cols.size());
    reserve_block(m_columns, rows, cols, std::max<Index>(rows + 1, 64), std::max<Index>(cols, 16));
    for (Index p = 0; p < cols; ++p)
        m_columns(rows, p) = coupling_between(c, m_cols[static_cast<std::size_t>(p)]);
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
        auto values = m_columns.col(cols).head(rows);
        values.setZero();
        const Record& record_d = m_records[static_cast<std::size_t>(d)];
        for (int sd = 0; sd < record_d.num_sides; ++sd) {
            const Side& side_d = record_d.sides[static_cast<std::size_t>(sd)];
            double scale = 1.0;
            const auto z = response(side_d, scale);
            for (Index r = 0; r < rows; ++r) {
                const Record& record_c
                    = m_records[static_cast<std::size_t>(m_rows[static_cast<std::size_t>(r)])];
                for (int sc = 0; sc < record_c.num_sides; ++sc) {
                    const Side& side_c = record_c.sides[static_cast<std::size_t>(sc)];
                    if (side_c.body == side_d.body)
                        values(r) += scale * side_apply(side_c, z);
                }
            }
        }
        m_cols.push_back(d);
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
    const Index m = static_cast<Index>(m_records.size());
    for (Index a = 0; a < m; ++a) {
        if (!(forces.row(a).squaredNorm() > 0.0))
            continue;
        const Record& record = m_records[static_cast<std::size_t>(a)];
        for (int s = 0; s < record.num_sides; ++s) {
            const Side& side = record.sides[static_cast<std::size_t>(s)];
            BodyData& data = m_data[static_cast<std::size_t>(side.body)];
            double scale = 1.0;
            const auto z = response(side, scale);
            const Eigen::RowVector3d f = scale * forces.row(a);
            if (all_rows || data.read_rows.empty())
                data.displacement.noalias() += z * f;
            else
                for (const int r : data.read_rows)
                    data.displacement.row(r) += z(r) * f;
        }
    }
}

// x_c = x_free_c + sum over c's sides of J_cb (sum_d z_d f_d^T): the same as W f, without W.
void ContactStage::displace(const Eigen::Ref<const MatX3>& free,
    const Eigen::Ref<const MatX3>& forces, const std::vector<char>* keep,
    Eigen::Ref<MatX3> positions)
{
    sum_responses(forces, false);
    const Index m = static_cast<Index>(m_records.size());
    for (Index c = 0; c < m; ++c) {
        if (keep != nullptr && (*keep)[static_cast<std::size_t>(c)])
            continue;
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
    }
}

} // namespace mat
