#include "runtime/pd/contact.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/error.hpp"

namespace mat {

std::vector<int> boundary_nodes(const Eigen::Ref<const MatX4i>& tets, Index num_nodes)
{
    // A face is on the boundary iff exactly one tet has it: sort the sorted-corner triples.
    std::vector<std::array<int, 3>> faces;
    faces.reserve(4 * static_cast<std::size_t>(tets.rows()));
    for (Index e = 0; e < tets.rows(); ++e)
        for (int skip = 0; skip < 4; ++skip) {
            std::array<int, 3> face {};
            int f = 0;
            for (int c = 0; c < 4; ++c)
                if (c != skip)
                    face[f++] = tets(e, c);
            std::sort(face.begin(), face.end());
            faces.push_back(face);
        }
    std::sort(faces.begin(), faces.end());
    std::vector<char> on_boundary(num_nodes, 0);
    for (std::size_t i = 0; i < faces.size();) {
        std::size_t j = i + 1;
        while (j < faces.size() && faces[j] == faces[i])
            ++j;
        if (j - i == 1)
            for (const int v : faces[i])
                on_boundary[v] = 1;
        i = j;
    }
    std::vector<int> nodes;
    for (Index i = 0; i < num_nodes; ++i)
        if (on_boundary[i])
            nodes.push_back(static_cast<int>(i));
    return nodes;
}

DenseContactCoupling::DenseContactCoupling(const Eigen::Ref<const MatX>& coupling)
    : m_coupling(coupling)
    , m_diagonal(coupling.diagonal())
{
    MAT_CHECK(coupling.rows() == coupling.cols(), "contact solve: the coupling is {} x {}",
        coupling.rows(), coupling.cols());
}

void DenseContactCoupling::displace(const Eigen::Ref<const MatX3>& free,
    const Eigen::Ref<const MatX3>& forces, const std::vector<char>* keep,
    Eigen::Ref<MatX3> positions)
{
    const Index m = m_coupling.rows();
    for (Index c = 0; c < m; ++c)
        if (keep == nullptr || !(*keep)[static_cast<std::size_t>(c)])
            positions.row(c) = free.row(c);
    for (Index d = 0; d < m; ++d)
        if (forces.row(d).squaredNorm() > 0.0)
            for (Index c = 0; c < m; ++c)
                if (keep == nullptr || !(*keep)[static_cast<std::size_t>(c)])
                    positions.row(c) += m_coupling(c, d) * forces.row(d);
}

namespace {

    /// One contact solve's data, with the steps of its projected Gauss-Seidel (docs/method.md,
    /// section 5).
    struct PlaneContactSolve {
        ContactCoupling& coupling;
        const VecX& diagonal;
        const std::vector<PlaneCollider>& planes;
        const std::vector<ContactPair>& pairs;
        const Eigen::Ref<const MatX3>& free_positions;
        const Eigen::Ref<const MatX3>& start_positions;
        Eigen::Ref<MatX3>& forces;
        Eigen::Ref<MatX3>& positions;

        /// Contact c's gap, at x + eps (f - preload n) with compliance.
        double gap_of(Index c) const
        {
            const PlaneCollider& plane = planes[pairs[c].plane];
            const double eps = std::max(plane.compliance * diagonal(c), plane.compliance_floor);
            return plane.normal.dot(
                       positions.row(c).transpose() + eps * forces.row(c).transpose() - plane.point)
                - eps * plane.preload;
        }

        /// Whether contact c pushes or is not clear of its plane.
        bool in_working_set(Index c) const
        {
            return forces.row(c).squaredNorm() > 0.0 || !(gap_of(c) > 0.0);
        }

        /// Working member k's new force (Signorini normal, Coulomb tangent), and the working
        /// set's positions (kept in `scratch`, contiguous) moved by the change; returns how far
        /// it moves (0 if its force is unchanged).
        double project(std::size_t k, ContactScratch& scratch)
        {
            const Index c = scratch.working[k];
            const PlaneCollider& plane = planes[pairs[c].plane];
            const double coupling_cc = diagonal(c);
            if (!(coupling_cc > 0.0))
                return 0.0; // a node the global step cannot move (cannot happen for SPD)
            // With compliance the conditions hold at x + eps f, which moves by (D_cc + eps) per
            // unit force.
            const double eps = std::max(plane.compliance * coupling_cc, plane.compliance_floor);
            const double w = coupling_cc + eps;
            const Vec3 n = plane.normal;
            const Index kk = static_cast<Index>(k);
            Vec3 x = scratch.working_positions.row(kk).transpose();
            if (scratch.through_bodies)
                x += coupling.moved(c);
            x += eps * forces.row(c).transpose();
            const Vec3 f = forces.row(c).transpose();
            // Normal: the force that closes the gap (or none), Signorini.
            const double gap = n.dot(x - plane.point) - eps * plane.preload;
            // No force and a gap that is not negative: no force again (the friction disk is a
            // point), so nothing changes. Taken before the tangent's divisions and roots: in a
            // large working set many are such contacts (docs/method.md, "W in node space").
            if (gap >= 0.0 && f.x() == 0.0 && f.y() == 0.0 && f.z() == 0.0)
                return 0.0;
            const double f_n = n.dot(f);
            const Vec3 f_t = f - f_n * n;
            const double f_n_new = std::max(0.0, f_n - gap / w);
            // Tangent: the force that cancels the tangential displacement since the step start
            // (stick), projected onto the friction disk |f_t| <= mu f_n (slip).
            Vec3 u = x - start_positions.row(c).transpose();
            u -= n.dot(u) * n;
            Vec3 f_t_new = f_t - u / w;
            const double limit = plane.friction * f_n_new;
            const double norm_t = f_t_new.norm();
            if (norm_t > limit)
                f_t_new *= (norm_t > 0.0 ? limit / norm_t : 0.0);

            const Vec3 delta = (f_n_new - f_n) * n + (f_t_new - f_t);
            if (delta.squaredNorm() == 0.0)
                return 0.0;
            forces.row(c) = (f_n_new * n + f_t_new).transpose();
            if (scratch.through_bodies) {
                coupling.push(c, delta);
                return coupling_cc * delta.norm();
            }
            const Index size = static_cast<Index>(scratch.working.size());
            if (scratch.contiguous) {
                const Eigen::Map<const VecX> column(
                    coupling.column(c) + scratch.rows.front(), size);
                scratch.working_positions.topRows(size).noalias() += column * delta.transpose();
                return coupling_cc * delta.norm();
            }
            if (!scratch.ready[k]) {
                const double* column = coupling.column(c);
                for (Index j = 0; j < size; ++j)
                    scratch.working_columns(j, kk)
                        = column[scratch.rows[static_cast<std::size_t>(j)]];
                scratch.ready[k] = 1;
            }
            scratch.working_positions.topRows(size).noalias()
                += scratch.working_columns.col(kk).head(size) * delta.transpose();
            return coupling_cc * delta.norm();
        }

        /// One sweep over the working set, in order: the largest position change.
        double sweep(ContactScratch& scratch)
        {
            double change = 0.0;
            for (std::size_t k = 0; k < scratch.working.size(); ++k)
                change = std::max(change, project(k, scratch));
            return change;
        }

        /// Adds the contacts that have come into their plane to `member`, the deepest of their
        /// penetrations in `depth`; false if none joins.
        bool join(std::vector<char>& member, double& depth) const
        {
            const Index m = static_cast<Index>(pairs.size());
            bool joined = false;
            for (Index c = 0; c < m; ++c)
                if (!member[static_cast<std::size_t>(c)] && in_working_set(c)) {
                    member[static_cast<std::size_t>(c)] = 1;
                    joined = true;
                    depth = std::max(depth, -gap_of(c));
                }
            return joined;
        }
    };

} // namespace

ContactSolveResult solve_plane_contacts(ContactCoupling& coupling,
    const std::vector<PlaneCollider>& planes, const std::vector<ContactPair>& pairs,
    const Eigen::Ref<const MatX3>& free_positions, const Eigen::Ref<const MatX3>& start_positions,
    Eigen::Ref<MatX3> forces, Eigen::Ref<MatX3> positions, const ContactSettings& settings)
{
    ContactScratch scratch;
    return solve_plane_contacts(coupling, planes, pairs, free_positions, start_positions, forces,
        positions, settings, scratch);
}

ContactSolveResult solve_plane_contacts(ContactCoupling& coupling,
    const std::vector<PlaneCollider>& planes, const std::vector<ContactPair>& pairs,
    const Eigen::Ref<const MatX3>& free_positions, const Eigen::Ref<const MatX3>& start_positions,
    Eigen::Ref<MatX3> forces, Eigen::Ref<MatX3> positions, const ContactSettings& settings,
    ContactScratch& scratch)
{
    const Index m = static_cast<Index>(pairs.size());
    const VecX& diagonal = coupling.diagonal();
    MAT_CHECK(diagonal.size() == m && free_positions.rows() == m && start_positions.rows() == m
            && forces.rows() == m && positions.rows() == m,
        "contact solve: inconsistent sizes for {} contacts", m);
    ContactSolveResult result;
    if (m == 0)
        return result;

    // x = x_free + D f for the warm-start forces.
    PlaneContactSolve solve { coupling, diagonal, planes, pairs, free_positions, start_positions,
        forces, positions };
    coupling.displace(free_positions, forces, nullptr, positions);

    // Projected Gauss-Seidel over a working set: the contacts that push or are not clear of
    // their plane. The others would change nothing in a sweep (no force, and a positive gap
    // gives none), so a sweep runs over the working set only and keeps only its positions up
    // to date; once it has converged, every position is brought up to date and a contact that
    // has come into its plane joins, and the sweeps go on (sweeping all contacts would act on
    // it in the sweep it came into its plane; both converge to the same conditions).
    std::vector<Index>& working = scratch.working;
    std::vector<int>& rows = scratch.rows;
    std::vector<char>& member = scratch.member;
    member.resize(static_cast<std::size_t>(m));
    for (Index c = 0; c < m; ++c)
        member[static_cast<std::size_t>(c)] = solve.in_working_set(c) ? 1 : 0;

    int sweep = 0;
    while (true) {
        working.clear();
        for (Index c = 0; c < m; ++c)
            if (member[static_cast<std::size_t>(c)])
                working.push_back(c);
        rows.clear();
        scratch.through_bodies = coupling.sweep_through_bodies(working);
        if (!scratch.through_bodies)
            for (const Index c : working)
                rows.push_back(coupling.cover(c));
        // The sweeps on contiguous copies of the working set's positions and columns.
        const Index size = static_cast<Index>(working.size());
        if (scratch.working_positions.rows() < size)
            scratch.working_positions.resize(
                std::max(size, 2 * scratch.working_positions.rows()), 3);
        for (Index k = 0; k < size; ++k)
            scratch.working_positions.row(k) = positions.row(working[static_cast<std::size_t>(k)]);
        scratch.contiguous = !scratch.through_bodies;
        for (std::size_t j = 1; j < rows.size() && scratch.contiguous; ++j)
            scratch.contiguous = rows[j] == rows[0] + static_cast<int>(j);
        const bool copies = !scratch.contiguous && !scratch.through_bodies;
        if (copies && scratch.working_columns.rows() < size)
            scratch.working_columns.resize(
                std::max(size, 2 * scratch.working_columns.rows()), scratch.working_columns.cols());
        if (copies && scratch.working_columns.cols() < size)
            scratch.working_columns.resize(
                scratch.working_columns.rows(), std::max(size, 2 * scratch.working_columns.cols()));
        scratch.ready.assign(working.size(), 0);
        for (; sweep < settings.max_sweeps; ++sweep) {
            const double change = solve.sweep(scratch);
            result.sweeps = sweep + 1;
            result.last_change = change;
            if (change <= settings.tolerance) {
                ++sweep;
                break;
            }
        }
        for (Index k = 0; k < size; ++k) {
            const Index c = working[static_cast<std::size_t>(k)];
            positions.row(c) = scratch.working_positions.row(k);
            if (scratch.through_bodies)
                positions.row(c) += coupling.moved(c).transpose();
        }
        if (sweep >= settings.max_sweeps && !settings.outside_positions)
            break;
        // Every other position from the forces, then the contacts that have come into their
        // plane.
        coupling.displace(free_positions, forces, &member, positions);
        double depth = 0.0; // the deepest of the contacts that join
        if (!solve.join(member, depth))
            break;
        if (sweep >= settings.max_sweeps) {
            // No sweep left for them: not converged.
            result.last_change = std::max(result.last_change, depth);
            break;
        }
    }
    return result;
}

} // namespace mat
