#include "runtime/pd/contact.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

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
        /// Whether the planes' compliance caps bind (ContactSettings::compliance_caps).
        bool caps = true;

        /// Contact c's compliance eps (its conditions hold at x + eps f).
        double compliance_of(Index c) const
        {
            const PlaneCollider& plane = planes[pairs[c].plane];
            return std::max(plane.compliance * diagonal(c), plane.compliance_floor);
        }

        /// The gap at x + eps (f - preload n) (`linear_gap`, the compliance uncapped) with
        /// the compliance's give along the normal held to the plane's cap: past it, the part
        /// of the give over the cap is taken back.
        double capped_gap(
            const PlaneCollider& plane, double eps, double f_n, double linear_gap) const
        {
            const double give = eps * (f_n - plane.preload);
            const double cap = cap_of(plane);
            return give > cap ? linear_gap - give + cap : linear_gap;
        }

        /// The plane's cap on the compliance's give where caps bind, else none.
        double cap_of(const PlaneCollider& plane) const
        {
            return caps ? plane.compliance_cap : std::numeric_limits<double>::infinity();
        }

        /// Contact c's gap, at x + eps (f - preload n) with compliance (its normal give capped).
        double gap_of(Index c) const
        {
            const PlaneCollider& plane = planes[pairs[c].plane];
            const double eps = compliance_of(c);
            const double linear = plane.normal.dot(positions.row(c).transpose()
                                      + eps * forces.row(c).transpose() - plane.point)
                - eps * plane.preload - plane.offset;
            return capped_gap(plane, eps, plane.normal.dot(forces.row(c).transpose()), linear);
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
            const double eps = compliance_of(c);
            const double w = coupling_cc + eps;
            const Vec3 n = plane.normal;
            const Index kk = static_cast<Index>(k);
            Vec3 x = scratch.working_positions.row(kk).transpose();
            if (scratch.through_bodies)
                x += coupling.moved(c);
            x += eps * forces.row(c).transpose();
            const Vec3 f = forces.row(c).transpose();
            // Normal: the force that closes the gap (or none), Signorini.
            const double f_n = n.dot(f);
            const double linear_gap = n.dot(x - plane.point) - eps * plane.preload - plane.offset;
            const double gap = capped_gap(plane, eps, f_n, linear_gap);
            // No force and a gap that is not negative: no force again (the friction disk is a
            // point), so nothing changes. Taken before the tangent's divisions and roots: in a
            // large working set many are such contacts (docs/method.md, "W in node space").
            if (gap >= 0.0 && f.x() == 0.0 && f.y() == 0.0 && f.z() == 0.0)
                return 0.0;
            const Vec3 f_t = f - f_n * n;
            // The give grows with the force (w per unit force) up to its cap, past which the
            // contact is hard (D_cc per unit force): the new force on the branch it lands on.
            double f_n_new = std::max(0.0, f_n - linear_gap / w);
            const double cap = cap_of(plane);
            if (eps * (f_n_new - plane.preload) > cap) {
                const double hard_gap = linear_gap - eps * (f_n - plane.preload);
                f_n_new = std::max(0.0, f_n - (hard_gap + cap) / coupling_cc);
            }
            // Tangent: the force that cancels the tangential displacement since the step start
            // (stick), projected onto the friction disk |f_t| <= mu f_n (slip).
            Vec3 u = x - start_positions.row(c).transpose();
            u -= n.dot(u) * n;
            Vec3 f_t_new = f_t - u / w;
            const double limit = plane.friction * f_n_new;
            // The root only where the force may slip: well inside the disk (a margin for the
            // rounding of the squares) the test below cannot pass.
            if (!(f_t_new.squaredNorm() < (1.0 - 1e-12) * (limit * limit))) {
                const double norm_t = f_t_new.norm();
                if (norm_t > limit)
                    f_t_new *= (norm_t > 0.0 ? limit / norm_t : 0.0);
            }

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

        /// Where contact c's x + eps f must be for it to stick: on its plane (at the preload's
        /// offset), tangentially where it started the step; minus where it is.
        Vec3 residual(Index c, Index k, const ContactScratch& scratch) const
        {
            const PlaneCollider& plane = planes[pairs[c].plane];
            const double eps = compliance_of(c);
            const Vec3& n = plane.normal;
            const Vec3 start = start_positions.row(c).transpose();
            const Vec3 target
                = start + (n.dot(plane.point - start) + eps * plane.preload + plane.offset) * n;
            return target - scratch.working_positions.row(k).transpose()
                - eps * forces.row(c).transpose();
        }

        /// A subspace step (docs/method.md, "Subspace steps"): with the working contacts that
        /// push split into those that stick (the tangent strictly inside the friction disk) and
        /// the others (slipping, or without friction), the step to the forces that meet their
        /// conditions as equalities, every other force held: x_c + eps_c f_c at its target in
        /// all three directions for one that sticks (S), along its normal only for the others
        /// (L, their tangential force held, their change lambda_c n_c). The step is cut short
        /// where a sticking force would leave its cone or another's normal force would change
        /// sign (a slipping contact whose normal force falls is brought back onto its friction
        /// disk by the next sweep); the sweeps that follow correct what the held forces and a
        /// wrong split leave.
        void subspace(ContactScratch& scratch, int limit)
        {
            const Index q = split_pushing(scratch);
            if (q < 2 || q > limit || !subspace_changes(scratch))
                return;
            auto changes = scratch.subspace_rhs.topRows(q);
            double fraction = 1.0;
            for (Index i = 0; i < q; ++i) {
                const Index c = pushing_contact(scratch, i);
                const PlaneCollider& plane = planes[pairs[c].plane];
                const Vec3 f = forces.row(c).transpose();
                const Vec3 d = changes.row(i).transpose();
                fraction = std::min(fraction,
                    i < scratch.sticking ? cone_fraction(f, d, plane.normal, plane.friction)
                                         : normal_fraction(f, d, plane.normal));
            }
            if (!(fraction > 0.0))
                return;
            const Index size = static_cast<Index>(scratch.working.size());
            for (Index i = 0; i < q; ++i) {
                const Index c = pushing_contact(scratch, i);
                const Vec3 delta = fraction * changes.row(i).transpose();
                forces.row(c) += delta.transpose();
                const double* column = coupling.column(c);
                if (scratch.contiguous) {
                    const Eigen::Map<const VecX> in_place(column + scratch.rows.front(), size);
                    scratch.working_positions.topRows(size).noalias()
                        += in_place * delta.transpose();
                } else
                    for (Index k = 0; k < size; ++k)
                        scratch.working_positions.row(k)
                            += column[scratch.rows[static_cast<std::size_t>(k)]]
                            * delta.transpose();
            }
        }

        /// The working members that push into scratch.pushing, those that stick first
        /// (scratch.sticking of them); returns how many push.
        Index split_pushing(ContactScratch& scratch) const
        {
            std::vector<Index>& pushing = scratch.pushing;
            pushing.clear();
            scratch.sticking = 0;
            for (int pass = 0; pass < 2; ++pass) {
                for (std::size_t k = 0; k < scratch.working.size(); ++k) {
                    const Index c = scratch.working[k];
                    const PlaneCollider& plane = planes[pairs[c].plane];
                    const Vec3 f = forces.row(c).transpose();
                    const double f_n = plane.normal.dot(f);
                    if (!(f_n > 0.0))
                        continue;
                    // Strictly inside, with room for the rounding of a projection onto the disk.
                    const bool sticks
                        = (f - f_n * plane.normal).norm() < (1.0 - 1e-6) * plane.friction * f_n;
                    if (sticks == (pass == 0))
                        pushing.push_back(static_cast<Index>(k));
                }
                if (pass == 0)
                    scratch.sticking = static_cast<Index>(pushing.size());
            }
            return static_cast<Index>(pushing.size());
        }

        /// The pushing member i's contact.
        static Index pushing_contact(const ContactScratch& scratch, Index i)
        {
            return scratch
                .working[static_cast<std::size_t>(scratch.pushing[static_cast<std::size_t>(i)])];
        }

        /// The subspace step's force changes, one row per pushing member, into
        /// scratch.subspace_rhs; false if a factorization fails. With A = D + E over the
        /// pushing members (E their compliances), K = A_SS and R their residuals:
        ///   K F_S + A_SL diag(lambda) N_L = R_S,
        ///   n_i . (A_LS F_S + sum_k A_ik lambda_k n_k)_i = n_i . R_i   (i in L),
        /// solved through the Schur complement of K (D is isotropic, so one scalar Cholesky of
        /// K serves the three directions): (T o G) lambda = n . (R_L - A_LS K^-1 R_S) with
        /// T = A_LL - A_LS K^-1 A_SL and G_ik = n_i . n_k, then
        /// F_S = K^-1 (R_S - A_SL diag(lambda) N_L).
        bool subspace_changes(ContactScratch& scratch) const
        {
            const Index q = static_cast<Index>(scratch.pushing.size());
            const Index s = scratch.sticking;
            const Index l = q - s;
            grow(scratch.subspace_matrix, q, q);
            grow(scratch.subspace_cross, s, l);
            if (scratch.subspace_rhs.rows() < q)
                scratch.subspace_rhs.resize(std::max(q, 2 * scratch.subspace_rhs.rows()), 3);
            auto a = scratch.subspace_matrix.topLeftCorner(q, q);
            auto r = scratch.subspace_rhs.topRows(q);
            for (Index j = 0; j < q; ++j) { // A's lower triangle, and R
                const Index c = pushing_contact(scratch, j);
                const double* column = coupling.column(c);
                a(j, j) = diagonal(c) + compliance_of(c);
                for (Index i = j + 1; i < q; ++i)
                    a(i, j) = column[scratch.rows[static_cast<std::size_t>(
                        scratch.pushing[static_cast<std::size_t>(i)])]];
                r.row(j) = residual(c, scratch.pushing[static_cast<std::size_t>(j)], scratch)
                               .transpose();
            }
            auto k_ss = a.topLeftCorner(s, s);
            auto a_ls = a.bottomLeftCorner(l, s);
            auto t = a.bottomRightCorner(l, l);
            auto x = scratch.subspace_cross.topLeftCorner(s, l);
            auto r_s = r.topRows(s);
            auto r_l = r.bottomRows(l);
            Eigen::LLT<Eigen::Ref<MatX>> k_factor(k_ss);
            if (k_factor.info() != Eigen::Success)
                return false;
            if (s > 0) {
                k_factor.solveInPlace(r_s); // K^-1 R_S
                if (l > 0) {
                    x = a_ls.transpose();
                    k_factor.solveInPlace(x); // K^-1 A_SL
                    t.template triangularView<Eigen::Lower>() -= a_ls * x;
                    r_l.noalias() -= a_ls * r_s;
                }
            }
            if (l == 0)
                return true;
            for (Index j = 0; j < l; ++j) {
                const Vec3& n_j = planes[pairs[pushing_contact(scratch, s + j)].plane].normal;
                for (Index i = j + 1; i < l; ++i)
                    t(i, j) *= n_j.dot(planes[pairs[pushing_contact(scratch, s + i)].plane].normal);
                r_l(j, 0) = n_j.dot(r_l.row(j).transpose()); // lambda, once solved
            }
            Eigen::LLT<Eigen::Ref<MatX>> t_factor(t);
            if (t_factor.info() != Eigen::Success)
                return false;
            auto lambda = r_l.col(0);
            t_factor.solveInPlace(lambda);
            // The rows of L become lambda_j n_j; F_S -= K^-1 A_SL (those rows).
            for (Index j = 0; j < l; ++j)
                r_l.row(j) = r_l(j, 0)
                    * planes[pairs[pushing_contact(scratch, s + j)].plane].normal.transpose();
            if (s > 0)
                r_s.noalias() -= x * r_l;
            return true;
        }

        static void grow(MatX& matrix, Index rows, Index cols)
        {
            if (matrix.rows() < rows || matrix.cols() < cols)
                matrix.resize(std::max(rows, 2 * matrix.rows()), std::max(cols, 2 * matrix.cols()));
        }

        /// The largest a in [0, 1] with n . (f + a d) >= 0, n . f > 0.
        static double normal_fraction(const Vec3& f, const Vec3& d, const Vec3& n)
        {
            const double f_n = n.dot(f);
            const double d_n = n.dot(d);
            return f_n + d_n >= 0.0 ? 1.0 : f_n / -d_n;
        }

        /// The largest a in [0, 1] with f + a d in the friction cone {|g_t| <= mu g_n} of normal
        /// n, f inside it (the cone is convex, so the segment leaves it at most once).
        static double cone_fraction(const Vec3& f, const Vec3& d, const Vec3& n, double mu)
        {
            const auto inside = [&](double a) {
                const Vec3 g = f + a * d;
                const double g_n = n.dot(g);
                return g_n >= 0.0 && (g - g_n * n).norm() <= mu * g_n;
            };
            if (inside(1.0))
                return 1.0;
            double low = 0.0;
            double high = 1.0;
            for (int i = 0; i < 40; ++i) {
                const double mid = 0.5 * (low + high);
                (inside(mid) ? low : high) = mid;
            }
            return low;
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
    solve.caps = settings.compliance_caps;
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
        for (int since = 1; sweep < settings.max_sweeps; ++sweep, ++since) {
            const double change = solve.sweep(scratch);
            result.sweeps = sweep + 1;
            result.last_change = change;
            if (change <= settings.tolerance) {
                ++sweep;
                break;
            }
            // Not after the last sweep: a step's forces are left to the sweeps to correct.
            if (settings.subspace_every > 0 && since % settings.subspace_every == 0
                && !scratch.through_bodies && sweep + 1 < settings.max_sweeps)
                solve.subspace(scratch, settings.subspace_limit);
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
