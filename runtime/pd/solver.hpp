#pragma once
// Implicit Euler projective dynamics (Bouaziz et al. 2014; semi-reduced as in Lan et al. 2020,
// docs/method.md, section 3). Both solvers share the full-space local step and the contact solve;
// the global step is either the reduced k x k solve (SemiReducedSolver) or the full n x n CHOLMOD
// solve (FullSolver, the accuracy reference and speed baseline).
//
// Per step, with h = dt, M the lumped masses, g the gravity acceleration:
//   s = x_n + h v_n + h^2 g                       (inertia target)
//   contact candidates: boundary nodes within `contact_margin` of a plane at x_n or at s, and
//     the contacts between bodies the driver gives (runtime/pd/contact_stage.hpp)
//   x = s; repeat `iterations` times:
//     local step at x -> r;  global step A x = M s / h^2 + r + P p  (p: the pin targets now)
//     contact stage on the global steps' results: exact Signorini-Coulomb conditions for every
//     contact of every body, inside the iteration (docs/method.md, "Contact")
//   v_{n+1} = (1 - damping) (x - x_n) / h
// Damping: `damping` in [0, 1) scales the velocity at the end of each step (0 = none). It is a
// simple numerical damping (it removes the fraction `damping` of the velocity per step, so its
// effect depends on dt), not Rayleigh damping. Implicit Euler itself dissipates energy too.
// Pinned nodes follow the targets set with set_pin_targets() (kinematic motion), by default the
// model's.
// A solver holds only workspace (and, for FullSolver, the CHOLMOD factor) for the one Model it
// was made for, which must outlive it; step() allocates nothing once the workspace exists,
// except when the set of contact candidates grows past anything seen before.

#include <functional>
#include <memory>
#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/contact.hpp"
#include "runtime/pd/contact_stage.hpp"
#include "runtime/pd/global_step.hpp"
#include "runtime/pd/local_step.hpp"
#include "runtime/state.hpp"

namespace mat {

struct SolverOptions {
    int iterations = 10; ///< local/global iterations per step, >= 1
    Vec3 gravity = Vec3(0.0, -9.81, 0.0); ///< external acceleration, m/s^2
    double damping = 0.0; ///< velocity scaling per step, in [0, 1)
    std::vector<PlaneCollider> planes; ///< ground planes (unit normals)
    double contact_margin = 0.01; ///< candidate distance, relative to the rest bounding box
    ContactSettings
        contact; ///< contact solve settings (tolerance relative to the rest bounding box)
    /// The local step's decomposition: exact (double precision everywhere) or fast (float
    /// eigenvectors; exact at rest and under rigid motion). See ProjectionParams::exact.
    bool exact_projections = false;
    /// Compliance of the contacts between bodies (the contact stage's; PlaneCollider::compliance):
    /// without it, a reduced body pressed by more contacts than it has degrees of freedom takes
    /// unbounded forces (strains of 2 to 10 on stacked 2-handle capsules). Ground planes stay hard.
    double node_contact_compliance = 0.1;
};

/// What the last step did.
struct StepReport {
    int contacts = 0; ///< contact candidates (node, plane)
    int active_contacts = 0; ///< candidates with a non-zero force after the last iteration
    int contact_sweeps = 0; ///< Gauss-Seidel sweeps, summed over iterations
    double max_penetration = 0.0; ///< deepest node below a plane at the end of the step (m)
    /// The contact forces on the body over the step times the step (N s): what the contacts
    /// added to its momentum.
    Vec3 contact_impulse = Vec3::Zero();
};

class PdSolver {
public:
    virtual ~PdSolver();

    /// One time step from `in` to `out` (n x 3 each; `out` is resized if needed, and may not be
    /// `in`), with this body's ground contacts only. `model` must be the solver's model.
    void step(const Model& model, const State& in, State& out);

    // The step in stages, for a driver that steps several bodies with one contact stage over
    // all of them (runtime/pd/contact_stage.hpp; Simulation::step):
    //   begin_step(in, out); contact_stage.begin_step(...);
    //   for each iteration: iterate(i); contact_stage.solve(); finish_iteration(i);
    //   contact_stage.end_step(); end_step();
    // `in` and `out` must stay in place until end_step().
    void begin_step(const State& in, State& out);
    void iterate(int iteration);
    void finish_iteration(int iteration);
    void end_step();

    /// Targets of the pinned nodes for the next steps  #pinned x 3 (kinematic motion).
    void set_pin_targets(const Eigen::Ref<const MatX3>& targets);
    const MatX3& pin_targets() const { return m_pin_targets; }

    const Model& model() const { return *m_model; }
    const SolverOptions& options() const { return m_options; }
    const SolverTimings& timings() const { return m_timings; }
    const StepReport& last_report() const { return m_report; }
    /// The kept reduced coordinates q  k x 3 (x = X + B q), or null for full-space PD.
    const MatX* reduced_coordinates() const { return m_global->reduced_coordinates(); }

    // For the contact stage, during a step:
    GlobalStep& global_step() { return *m_global; }
    const GlobalStep& global_step() const { return *m_global; }
    /// The step's inertia target s  n x 3.
    const MatX3& inertia_target() const { return m_inertia; }
    /// The step's positions  n x 3 (after the last finish_iteration, the step's result).
    const MatX3& step_positions() const { return m_out->positions; }
    StepReport& report() { return m_report; }
    void add_contact_seconds(double seconds) { m_timings.contact += seconds; }

protected:
    /// `full_local_step`: make the local step over every tet that the default local_global uses.
    PdSolver(const Model& model, const SolverOptions& options, std::unique_ptr<GlobalStep> global,
        bool full_local_step = true);
    SolverTimings& mutable_timings() { return m_timings; }

    /// One iteration's local step and global solve (the solution stays in the global step): at the
    /// iterate `positions`  n x 3 with the step's constant right-hand side `base`  n x 3 (inertia,
    /// pins, the global step's constant terms). By default the local step over every tet, then
    /// the global step's solve.
    virtual void local_global(const Model& model, int iteration,
        const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3>& base);
    /// False if local_global reads `positions` only at iteration 0 (the inertia target): the
    /// full iterate is then reconstructed after the last iteration only.
    virtual bool reads_iterate() const { return true; }

private:
    const Model* m_model;
    SolverOptions m_options;
    std::unique_ptr<GlobalStep> m_global;
    std::unique_ptr<LocalStep> m_local; ///< null unless full_local_step
    MatX3 m_pin_targets; ///< #pinned x 3
    MatX3 m_inertia; ///< s  n x 3
    MatX3 m_rhs; ///< n x 3
    MatX3 m_rhs_base; ///< n x 3, the terms of the right-hand side that stay fixed in a step
    SolverTimings m_timings;
    StepReport m_report;
    const State* m_in = nullptr; ///< the step's, between begin_step and end_step
    State* m_out = nullptr;
    /// The contact stage of step() (this body alone), made on its first use.
    std::unique_ptr<ContactStage> m_own_contacts;
    std::vector<ContactBodyState> m_own_state;
};

class SemiReducedSolver final : public PdSolver {
public:
    explicit SemiReducedSolver(const Model& model, const SolverOptions& options = {});
};

class FullSolver final : public PdSolver {
public:
    /// Factors the model's full system with CHOLMOD (throws mat::Error if that fails).
    explicit FullSolver(const Model& model, const SolverOptions& options = {});
};

} // namespace mat
