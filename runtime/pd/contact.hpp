#pragma once
// The contact solve with Coulomb friction, resolved inside each projective dynamics iteration
// (docs/method.md, "Contact": no penalty forces applied a step late). Written here for points
// against planes; the contact stage (contact_stage.hpp) gives it relative points of two bodies
// (a "node" below is then such a point, and D the Delassus operator W of the bodies).
//
// Why not a PD constraint with a weight: a unilateral contact constraint with a fixed weight
// changes the system matrix whenever the contact set changes (a refactorization), and a stiff
// weight on a node that is not penetrating holds it at its last iterate, so bodies stick to the
// ground. Instead each global step is followed by an exact contact solve on the same matrix:
// the global step is linear, so a force f_j (in right-hand-side units) added at node j moves
// node i by D_ij f_j after the solve, with the scalar coupling D_ij = e_i^T A^-1 e_j (full space)
// or b_i S^-1 b_j^T (reduced: b_i the basis row of node i); A acts alike on x, y and z, so D is
// isotropic. With x_free the positions the global step gives without contact forces, the contact
// forces solve the Signorini-Coulomb conditions (Jean and Moreau's non-smooth contact dynamics,
// as used for projective dynamics by Ly, Jouve and Bertails-Descoubes 2020):
//   x_c = x_free_c + sum_d D_cd f_d,   gap_c = n . (x_c - point) >= 0,   f_n >= 0,   f_n gap_c = 0,
//   |f_t| <= mu f_n, and f_t opposes the tangential displacement of the node since the start of
//   the step, which is zero while the node sticks (static friction).
// Solved by projected Gauss-Seidel over the contacts in a fixed order (deterministic), warm
// started from the previous iteration's forces. A sweep visits only the working set, the
// contacts that push or are not clear of their plane (the others would not change in that
// sweep), and updates only their positions; once it converges, all positions are updated and
// contacts that have come into their plane join, and the sweeps go on. (Sweeping all contacts
// would act on such a contact in the sweep it came into its plane; both converge to the same
// conditions.) On the demo's creature (580 candidates, about 20 pushing) this took the contact
// solve from 31 to 5 ms per step.

#include <limits>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// A half-space boundary {x : normal . (x - point) >= 0} with Coulomb friction.
struct PlaneCollider {
    Vec3 point = Vec3::Zero();
    Vec3 normal = Vec3::UnitY(); ///< unit length
    double friction = 0.5; ///< Coulomb coefficient mu >= 0
    /// Contact compliance, relative to the node's own coupling D_cc: the conditions hold for
    /// x_c + compliance D_cc f_c instead of x_c (0: a hard contact). A little compliance keeps
    /// the forces unique and bounded where more contacts press on a body than it has degrees
    /// of freedom (a reduced body against another body), at the price of a penetration of
    /// compliance D_cc |f_c|.
    double compliance = 0.0;
    /// A lower bound on that compliance, absolute (the solve's units, like D_cc; 0: none): the
    /// conditions hold at x + max(compliance D_cc, compliance_floor) f. The contact stage sets
    /// it for self contacts of reduced bodies (docs/method.md, "Self contacts of reduced bodies").
    double compliance_floor = 0.0;
    /// A normal force (the solve's units, >= 0) the compliance does not act on: the conditions
    /// hold at x + eps (f - preload n). A contact that pressed with this force in the last step
    /// and presses alike now rests at its plane, not eps |f| behind it (docs/method.md,
    /// "Compliance").
    double preload = 0.0;
    /// The gap the conditions keep (m): n . (x - point) >= offset. The collision world sets it
    /// (the skin between bodies, the self skin within one); the contact stage clears it on a
    /// contact between bodies where a stepped body keeps no skin, and lowers a self contact's
    /// to its start gap plus the body's self push, below 0 for a vertex that starts deeper than
    /// that (docs/method.md, "Skin", "Self skin", "Self contacts that start behind").
    double offset = 0.0;
    /// The most the compliance may give along the normal (m; infinity: no cap): the conditions
    /// hold at n . x + min(eps (f_n - preload), compliance_cap) (tangentially at x + eps f_t as
    /// before). Past it the contact is hard. The contact stage sets it for contacts between
    /// bodies (docs/method.md, "Compliance cap").
    double compliance_cap = std::numeric_limits<double>::infinity();
};

/// One candidate contact: a node against a plane.
struct ContactPair {
    int node = 0;
    int plane = 0;
};

struct ContactSettings {
    int max_sweeps = 200; ///< projected Gauss-Seidel sweeps per solve
    /// With contacts between bodies, the sweeps of a PD iteration's solve before the step's last
    /// (ContactStage): on creatures_collide and drop_on_pile 20 gave the same penetration and
    /// strain as 200 at a quarter of the contact time.
    int early_sweeps = 20;
    /// Stop when no position moves more than this in a sweep (m; the solvers take it relative
    /// to the rest bounding-box diagonal).
    double tolerance = 1e-7;
    /// When the sweeps run out: whether the positions of the contacts outside the working set
    /// are still brought up to date (and the depth of those that would join taken into
    /// ContactSolveResult::last_change). The contact stage reads only the forces and sets it
    /// false: that pass over every contact is then saved (docs/method.md, section 5,
    /// "Iterations").
    bool outside_positions = true;
    /// Sweeps through the bodies (ContactCoupling::sweep_through_bodies) when the working set
    /// holds more than this fraction of the rows one change of force moves through them (a
    /// contact's bodies' node counts): there the columns of W over the working set cost more,
    /// in their entries and their first writes, than the bodies' displacements. 0: always
    /// (where the coupling can), infinity: never. Measured on creatures_collide (docs/method.md,
    /// "Sweeps through the bodies").
    double through_bodies = 0.25;
    /// After every this many sweeps of a working set (0: never, the default), a subspace step:
    /// the step to the forces that meet the pushing contacts' conditions as equalities, the
    /// others held (docs/method.md, "Subspace steps"; solver.contact_subspace). Not in sweeps
    /// through the bodies.
    int subspace_every = 0;
    /// The most pushing contacts such a step solves for (dense Cholesky factors of that order).
    int subspace_limit = 256;
    /// Whether the planes' compliance caps bind (PlaneCollider::compliance_cap). The contact
    /// stage lets them bind in the step's last solve only (docs/method.md, "Compliance cap").
    bool compliance_caps = true;
};

struct ContactSolveResult {
    int sweeps = 0;
    /// Largest position change in the last sweep (m); when the sweeps ran out just as contacts
    /// came into their planes, at least their deepest penetration.
    double last_change = 0.0;
};

/// The solve's working storage, kept by the caller from one solve to the next.
struct ContactScratch {
    std::vector<Index> working; ///< the working set, increasing
    std::vector<int> rows; ///< the working set's rows in the coupling's columns
    std::vector<char> member; ///< per contact, whether it is in the working set
    /// During the sweeps over one working set: its positions, and the columns of D over it of
    /// the members whose force has changed (ready), contiguous for the sweeps' updates.
    /// Column-major: a force's change moves them by three contiguous updates (vectorized).
    Eigen::Matrix<double, Eigen::Dynamic, 3> working_positions;
    MatX working_columns;
    std::vector<char> ready;
    /// Whether the working set's rows are consecutive (rows[j] = rows[0] + j, as in a step's
    /// first solve, whose contacts are covered in working order): the sweeps then read the
    /// coupling's columns in place, with no copy into working_columns (whose pages, written for
    /// the first time, cost more than the copy on a machine whose page faults are dear).
    bool contiguous = false;
    /// Whether the sweeps over this working set move its points through the coupling's own
    /// per-body displacements (ContactCoupling::sweep_through_bodies): working_positions then
    /// hold the points at the start of the sweeps, and a point is that plus moved().
    bool through_bodies = false;
    /// The subspace steps' storage (docs/method.md, "Subspace steps"): the working members
    /// that push (indices into `working`, those that stick first, `sticking` of them), their
    /// block of D plus compliance (factored in place), K^-1 A_SL, and the residuals, then the
    /// force changes.
    std::vector<Index> pushing;
    Index sticking = 0;
    MatX subspace_matrix;
    MatX subspace_cross;
    Eigen::Matrix<double, Eigen::Dynamic, 3> subspace_rhs;
};

/// The coupling D between the contacts' points (m contacts) as the solve uses it; D is symmetric
/// positive semi-definite. A Gauss-Seidel sweep needs D only between the contacts of the working
/// set, and of those only the columns of the contacts whose force changes; D is kept as its
/// diagonal and the columns of the contacts that have pushed, over the rows of the contacts that
/// have been in a working set ("covered"), both grown on demand. The positions of the others
/// come from displace(), which need not form D (the contact stage takes them through each
/// body's summed response).
class ContactCoupling {
public:
    virtual ~ContactCoupling() = default;
    /// D_cc  m.
    virtual const VecX& diagonal() const = 0;
    /// Contact c's row in the columns, covering it first if it is not.
    virtual int cover(Index c) = 0;
    /// Column c of D over the covered rows (entry cover(d) is D_dc); valid until the next
    /// cover() of a contact not covered yet.
    virtual const double* column(Index c) = 0;
    /// positions.row(c) = free.row(c) + sum_d D_cd forces.row(d), for every contact c with
    /// keep[c] == 0 (`keep` null: every contact).   free, forces, positions  m x 3
    /// (`free` is solve_plane_contacts' free_positions; a coupling that holds the free positions
    /// itself, as the contact stage does, may take them from there instead.)
    virtual void displace(const Eigen::Ref<const MatX3>& free,
        const Eigen::Ref<const MatX3>& forces, const std::vector<char>* keep,
        Eigen::Ref<MatX3> positions)
        = 0;
    /// Whether the sweeps over `working` (increasing) should move the working points through
    /// the coupling's own displacements of the bodies (moved(), push()) instead of D's columns
    /// over the working set: where a force's change costs less that way than a column's update
    /// over a large working set (docs/method.md, "Sweeps through the bodies"). When it says
    /// yes, the working contacts' diagonal entries are ready, nothing is covered, and the
    /// displacements start at zero. By default: never.
    virtual bool sweep_through_bodies(const std::vector<Index>& /*working*/) { return false; }
    /// During sweeps through the bodies: how far contact c's point has moved since they began.
    virtual Vec3 moved(Index /*c*/) const { return Vec3::Zero(); }
    /// During sweeps through the bodies: contact c's force has changed by `delta`.
    virtual void push(Index /*c*/, const Vec3& /*delta*/) { }
};

/// A coupling given whole, m x m (small problems and tests).
class DenseContactCoupling final : public ContactCoupling {
public:
    explicit DenseContactCoupling(const Eigen::Ref<const MatX>& coupling);
    const VecX& diagonal() const override { return m_diagonal; }
    int cover(Index c) override { return static_cast<int>(c); }
    const double* column(Index c) override { return m_coupling.col(c).data(); }
    void displace(const Eigen::Ref<const MatX3>& free, const Eigen::Ref<const MatX3>& forces,
        const std::vector<char>* keep, Eigen::Ref<MatX3> positions) override;

private:
    MatX m_coupling;
    VecX m_diagonal;
};

/// Nodes on the boundary of a tet mesh (on a face that belongs to one tet), increasing.
/// `tets`  T x 4 with indices in [0, num_nodes).
std::vector<int> boundary_nodes(const Eigen::Ref<const MatX4i>& tets, Index num_nodes);

/// Solves the contact conditions above for `pairs` (m contacts).
///   coupling         D between the pairs' points (see ContactCoupling)
///   free_positions   m x 3: the pairs' node positions after the global step without contact
///   start_positions  m x 3: the pairs' node positions at the start of the time step
///   forces           m x 3: in: a warm start (zeros at first), out: the contact forces
///   positions        m x 3: out: the pairs' node positions with the contact forces (see
///                    ContactSettings::outside_positions)
/// Allocates nothing once `scratch` is warm (the overload without it allocates its own).
ContactSolveResult solve_plane_contacts(ContactCoupling& coupling,
    const std::vector<PlaneCollider>& planes, const std::vector<ContactPair>& pairs,
    const Eigen::Ref<const MatX3>& free_positions, const Eigen::Ref<const MatX3>& start_positions,
    Eigen::Ref<MatX3> forces, Eigen::Ref<MatX3> positions, const ContactSettings& settings,
    ContactScratch& scratch);
ContactSolveResult solve_plane_contacts(ContactCoupling& coupling,
    const std::vector<PlaneCollider>& planes, const std::vector<ContactPair>& pairs,
    const Eigen::Ref<const MatX3>& free_positions, const Eigen::Ref<const MatX3>& start_positions,
    Eigen::Ref<MatX3> forces, Eigen::Ref<MatX3> positions, const ContactSettings& settings = {});

} // namespace mat
