#pragma once
// Implicit Euler projective dynamics (Bouaziz et al. 2014; semi-reduced as in Lan et al. 2020,
// docs/method.md, section 3). One solver built from parts: a local stage (which tets the local
// step projects, and how their projections reach the global solve) and a global step (which
// system it solves), with the contact stage between the global solves and the positions. The
// three modes are compositions of those parts (make_solver):
//   semi-reduced: every tet's local step + the reduced k x k solve (ReducedGlobalStep);
//   full space:   every tet's local step + the full n x n CHOLMOD solve (FullGlobalStep, the
//                 accuracy reference and speed baseline);
//   hyper-reduced: a sample of tets, fitted to the reduced right-hand side (SampledLocalStage,
//                 runtime/pd/hyper_reduced.hpp) + the reduced solve.
//
// Per step, with h = dt, M the lumped masses, g the gravity acceleration:
//   s = x_n + h v_n + h^2 g                       (inertia target)
//   contact candidates: boundary nodes within `contact_margin` of a plane at x_n or at s, and
//     the contacts between bodies the driver gives (runtime/pd/contact_stage.hpp)
//   x = s; repeat `iterations` times:
//     local step at x -> r;  global step A x = M s / h^2 + r + P p  (p: the pin targets now)
//     contact stage on the global steps' results: exact Signorini-Coulomb conditions for every
//     contact of every body, inside the iteration (docs/method.md, "Contact")
//   v_{n+1} = (1 - damping) (x - x_n) / h, plus (angular_momentum free or keep, for the bodies
//     it names) the rigid rotation that gives back the angular momentum the internal forces
//     changed (runtime/pd/angular_momentum.hpp)
// With `acceleration` anderson, each iteration's global solution is extrapolated from the last
// ones (Anderson acceleration, runtime/pd/anderson.hpp) and an extrapolation that raises the PD
// energy (hyper-reduced: the fixed-point residual) is replaced by the plain iterate; steps with
// contact candidates run plain (docs/method.md, "Accelerated iterations").
// Damping: `damping` in [0, 1) scales the velocity at the end of each step (0 = none). It is a
// simple numerical damping (it removes the fraction `damping` of the velocity per step, so its
// effect depends on dt), not Rayleigh damping. Implicit Euler itself dissipates energy too.
// Pinned nodes follow the targets set with set_pin_targets() (kinematic motion), by default the
// model's.
// With `device` cuda (semi-reduced only) the local step and the reduced solve run on the GPU
// (runtime/gpu/device_step.hpp; docs/gpu.md): a step without contact candidates runs there whole,
// one CUDA graph of its iterations; in a step with candidates, q comes to the CPU's contact stage
// and back in every iteration.
// A solver holds only workspace (and, full space, the CHOLMOD factor) for the one Model it
// was made for, which must outlive it; step() allocates nothing once the workspace exists,
// except when the set of contact candidates grows past anything seen before.

#include <array>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/error.hpp"
#include "runtime/gpu/device_step.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/anderson.hpp"
#include "runtime/pd/angular_momentum.hpp"
#include "runtime/pd/contact.hpp"
#include "runtime/pd/contact_stage.hpp"
#include "runtime/pd/global_step.hpp"
#include "runtime/pd/local_step.hpp"
#include "runtime/state.hpp"

namespace mat {

/// semi: every tet's local step and the reduced global step; full: every tet's local step and the
/// full-space global step (the reference); hyper: a sample of tets fitted to the reduced global
/// step.
enum class SolverKind { semi_reduced, full, hyper_reduced };

/// "semi", "full" or "hyper" -> SolverKind; throws mat::Error otherwise.
SolverKind parse_solver_kind(const std::string& name);

/// The iteration within a step: plain local/global, or Anderson-accelerated with the energy
/// safeguard (runtime/pd/anderson.hpp; docs/method.md, "Accelerated iterations").
enum class Acceleration { none, anderson };

/// "none" or "anderson" -> Acceleration; throws mat::Error otherwise.
Acceleration parse_acceleration(const std::string& name);

/// Which bodies end a step with the angular momentum their external impulses give them
/// (runtime/pd/angular_momentum.hpp; docs/method.md, "Angular momentum"): none (integrator: what
/// implicit Euler and the iterations give), those without pins or contact candidates in the step
/// (free), or also those whose contact island the world does not hold (keep, the default).
enum class AngularMomentum { integrator, free, keep };
/// Where the semi-reduced step runs: the CPU, or a CUDA GPU (runtime/gpu/device_step.hpp;
/// docs/gpu.md). The full-space and hyper-reduced solvers run on the CPU only.
enum class Device { cpu, cuda };

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
    /// A contact between bodies that pressed in the last step takes that normal force as its
    /// preload (PlaneCollider::preload), so that a steady contact rests at its plane rather than
    /// the compliance's give inside it (docs/method.md, "Compliance"); on a contact only when
    /// every body it pushes has it. Off by default: on, full-space creatures_collide with
    /// angular_momentum "integrator" crushed.
    bool compliance_preload = false;
    /// A contact between bodies keeps the gap its plane sets (PlaneCollider::offset, the
    /// collision world's skin) only when every body it pushes has this; otherwise it keeps none
    /// (docs/method.md, "Skin"; mat-run sets it in every mode).
    bool contact_skin = false;
    /// The most the compliance of a contact between bodies may give along its normal beyond the
    /// skin, as a fraction of the smaller rest bounding-box diagonal (0: no cap); past it the
    /// contact is hard (PlaneCollider::compliance_cap). On a contact only when every body it
    /// pushes has it, the smaller of their caps (docs/method.md, "Compliance cap").
    double compliance_cap = 0.0;
    /// The fastest a self contact of this body pushes a vertex that starts the step behind its
    /// plane (deeper than the self skin) back out, in rest bounding-box diagonals per second: its
    /// plane's offset is at most the start gap plus this times the diagonal and the time step.
    /// A vertex pressed back in every step was pushed out at once every step before, and each
    /// push gave it speed: the energy of pressed bodies rose (docs/method.md, "Self contacts that
    /// start behind").
    double self_push_speed = std::numeric_limits<double>::infinity();
    /// A contact of a vertex against a face of this body (stepped) takes the face's outward
    /// normal at each iteration's positions, not only at the step's start (docs/method.md,
    /// "Planes that follow the iterate").
    bool planes_follow_iterate = true;
    /// The same for a self contact of this body (with planes_follow_iterate): false holds its
    /// face's plane for the step. Full-space and semi-reduced bodies hold them: with planes that
    /// turn, their self contacts raised the energy of a resting pile (full space) and crushed a
    /// run at 30 iterations (semi-reduced; docs/method.md, "Self contacts hold their planes").
    bool self_planes_follow_iterate = true;
    /// The step's contacts are found again at the iterate halfway through its iterations (the
    /// Simulation does it in a step where every stepped body has this, on the CPU's plain
    /// iteration, without hyper-reduced bodies; docs/method.md, "Contacts found again during
    /// the step").
    bool detect_in_step = false;
    Acceleration acceleration = Acceleration::none;
    int anderson_window = 5; ///< differences kept by Anderson acceleration, 1 .. 16
    Device device = Device::cpu;
    /// Stop a step's iterations once the global step's solution u is estimated to be within
    /// this of the converged step (0: run `iterations` every step; the most otherwise), then run
    /// one more, the last. The distance: mass-weighted RMS, sqrt(sum_j m_j (u_j - u*_j)^2 /
    /// sum_i m_i), relative to the rest bounding-box diagonal, with m_j the node masses in full
    /// space (the RMS node distance) and the diagonal of B^T M B on the reduced coordinates; it
    /// is estimated from the last changes of u, c rho / (1 - rho) (PdSolver::measure_change).
    /// The contact solve then stops at a tenth of it (if below contact.tolerance). The CPU path
    /// only.
    double tolerance = 0.0;
    /// Which bodies keep angular momentum (AngularMomentum); the CPU path only.
    AngularMomentum angular_momentum = AngularMomentum::keep;
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
    /// The moment of those impulses about the origin, each taken at the start-of-step position
    /// of the node it acts on (kg m^2/s; runtime/pd/angular_momentum.hpp).
    Vec3 contact_moment = Vec3::Zero();
    /// Whether a ground plane or a body that is not stepped (static, kinematic, asleep) pushed
    /// the body in the step.
    bool world_contact = false;
    /// Whether the body's contact island (the stepped bodies it pushed or was pushed by in the
    /// step, and theirs, and so on) holds a body with world_contact or pins: the world then
    /// takes part in the island's angular momentum (AngularMomentum::keep).
    bool world_held = false;
    /// With acceleration on and no contact candidates: the safeguard's measure of the last
    /// accepted iterate (set by each iterate(): its PD energy, J, or for the hyper-reduced
    /// solver its fixed-point residual), the extrapolated iterates accepted and those the
    /// safeguard refused (their iteration then restarted from the plain iterate).
    double energy = 0.0;
    int accelerated = 0;
    int rejected = 0;
};

/// One iteration's local half and the global solve it feeds: the local step's projections over
/// the tets this stage projects, turned into the global step's right-hand side, and the solve.
class LocalStage {
public:
    virtual ~LocalStage() = default;
    /// At the iterate `positions`  n x 3, with the step's constant right-hand side `base`  n x 3
    /// (inertia, pins, the global step's constant terms): projects, then solves with `global`,
    /// which keeps the solution.
    virtual void iterate(const Model& model, int iteration,
        const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3>& base,
        GlobalStep& global, SolverTimings& timings)
        = 0;
    /// False if iterate() reads `positions` only at iteration 0 (the inertia target): the full
    /// iterate is then reconstructed after the last iteration only.
    virtual bool reads_iterate() const = 0;
    /// How many tets the local step projects.
    virtual Index num_tets() const = 0;
    /// Whether an iteration never raises the PD energy (runtime/pd/pd_energy.hpp): then the
    /// accelerated iteration's safeguard is that energy, else the fixed-point residual.
    virtual bool descends() const { return false; }
    /// Whether iterate() also evaluates the PD energy of the iterate it projects (a stage that
    /// descends).
    virtual void set_energy(bool /*on*/) { }
    /// That energy at the last iterate() (with set_energy(true)): `positions` the iterate it read,
    /// `inertia` s, `pin_targets` #pinned x 3.
    virtual double energy(const Model& /*model*/, const Eigen::Ref<const MatX3>& /*positions*/,
        const Eigen::Ref<const MatX3>& /*inertia*/, const Eigen::Ref<const MatX3>& /*pin_targets*/)
    {
        throw_error("solver: this local stage has no energy");
    }
    /// The local step (its warm start goes into checkpoints).
    virtual LocalStep& local_step() = 0;
    const LocalStep& local_step() const { return const_cast<LocalStage*>(this)->local_step(); }
};

/// The local step over every tet (semi-reduced and full-space PD).
class EveryTetLocalStage final : public LocalStage {
public:
    EveryTetLocalStage(const Model& model, bool exact_projections);
    void iterate(const Model& model, int iteration, const Eigen::Ref<const MatX3>& positions,
        const Eigen::Ref<const MatX3>& base, GlobalStep& global, SolverTimings& timings) override;
    bool reads_iterate() const override { return true; }
    Index num_tets() const override { return m_num_tets; }
    bool descends() const override { return true; }
    void set_energy(bool on) override { m_local.set_energy(on); }
    double energy(const Model& model, const Eigen::Ref<const MatX3>& positions,
        const Eigen::Ref<const MatX3>& inertia,
        const Eigen::Ref<const MatX3>& pin_targets) override;
    LocalStep& local_step() override { return m_local; }

private:
    LocalStep m_local;
    MatX3 m_rhs; ///< n x 3, the assembled right-hand side when the global step needs it written
    Index m_num_tets = 0;
};

class PdSolver final {
public:
    /// A solver of `model` (which must outlive it) from its parts.
    PdSolver(const Model& model, const SolverOptions& options, std::unique_ptr<LocalStage> local,
        std::unique_ptr<GlobalStep> global);
    PdSolver(PdSolver&&) = default;
    ~PdSolver();

    /// One time step (the model's time step) from `in` to `out` (n x 3 each; `out` is resized if
    /// needed, and may not be `in`), with this body's ground contacts only.
    void step(const State& in, State& out);

    // The step in stages, for a driver that steps several bodies with one contact stage over
    // all of them (runtime/pd/contact_stage.hpp; Simulation::step):
    //   begin_step(in, out); contact_stage.begin_step(...);
    //   for each iteration i, last = is_last_iteration(i) (for all bodies), until a last one:
    //     iterate(i); contact_stage.solve(last); finish_iteration(i, last);
    //   contact_stage.end_step(); end_step();
    // `in` and `out` must stay in place until end_step().
    void begin_step(const State& in, State& out);
    void iterate(int iteration);
    void finish_iteration(int iteration, bool last);
    /// Whether iteration `iteration` is the step's last: it is the options' last, or (tolerance
    /// > 0) the iterate after the one before is estimated within the tolerance (converged()).
    bool is_last_iteration(int iteration) const;
    /// With tolerance > 0: whether the iterate is estimated to be within it of the converged
    /// step after the last finished iteration (see SolverOptions::tolerance).
    bool converged() const { return m_change < m_options.tolerance; }
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
    /// Replaces the kept q (a checkpoint's; not for full-space PD, which keeps none).
    void set_reduced_coordinates(const Eigen::Ref<const MatX>& q)
    {
        m_global->set_reduced_coordinates(q);
    }

    /// The GPU step (--device cuda), or null.
    DeviceSemiStep* device() { return m_device.get(); }
    /// --device cuda: a step leaves its result on the GPU, and the host's copy of `out` (its
    /// positions and velocities) and the CPU's q are stale until sync_state(out), which brings
    /// them over if `state` is that result (else, and on the CPU, it does nothing). Whoever
    /// reads a state between steps calls it first; whoever writes one calls state_written(), so
    /// that the next step uploads it.
    void sync_state(State& state);
    void state_written();
    /// Whether a node may be within the contact margin of a ground plane this step (the GPU
    /// finds the nearest; the contact stage looks for ground contacts only then). Always true
    /// on the CPU.
    bool planes_near() const { return !m_device || m_planes_near; }
    const LocalStage& local_stage() const { return *m_local; }
    LocalStage& local_stage() { return *m_local; }

    // For the contact stage, during a step:
    ContactResponse& contact_response() { return m_global->contact_response(); }
    /// The step's inertia target s  n x 3.
    const MatX3& inertia_target() const { return m_inertia; }
    /// The step's positions  n x 3 (after the last finish_iteration, the step's result).
    const MatX3& step_positions() const { return m_out->positions; }
    /// The step's start positions  n x 3 (on the host; between begin_step and end_step).
    const MatX3& step_start_positions() const { return m_in->positions; }
    StepReport& report() { return m_report; }
    void add_contact_seconds(double seconds) { m_timings.contact += seconds; }
    /// The contact stage's candidate nodes of this body in the step (set at its begin_step):
    /// the accelerated iteration runs only in steps without any.
    void set_contact_nodes(Index count) { m_contact_nodes = count; }

private:
    const Model* m_model;
    SolverOptions m_options;
    std::unique_ptr<LocalStage> m_local;
    std::unique_ptr<GlobalStep> m_global;
    MatX3 m_pin_targets; ///< #pinned x 3
    MatX3 m_inertia; ///< s  n x 3
    MatX3 m_rhs_base; ///< n x 3, the terms of the right-hand side that stay fixed in a step
    SolverTimings m_timings;
    StepReport m_report;
    const State* m_in = nullptr; ///< the step's, between begin_step and end_step
    State* m_out = nullptr;
    /// The contact stage of step() (this body alone), made on its first use.
    std::unique_ptr<ContactStage> m_own_contacts;
    std::vector<ContactBodyState> m_own_state;
    // The accelerated iteration (docs/method.md, "Accelerated iterations").
    Index m_contact_nodes = 0;
    bool m_accelerating = false; ///< in this step
    bool m_extrapolated = false; ///< the iterate the next iterate() reads is extrapolated
    AndersonAcceleration m_anderson;
    AngularMomentumKeeper m_angular;
    // The convergence test (SolverOptions::tolerance).
    double m_diagonal = 0.0; ///< the rest bounding-box diagonal
    VecX m_solution_masses;
    VecX m_previous_solution;
    std::array<double, 3> m_changes {}; ///< the last three iterations' changes, newest first
    double m_change = std::numeric_limits<double>::infinity(); ///< the estimated distance left
    VecX m_anderson_weights; ///< the least squares' weights (made on the first accelerated step)
    /// --device cuda: the step runs there; the CPU's global step stays the contact stage's
    /// view of it (q is brought over in each iteration of a step with contact candidates).
    std::unique_ptr<DeviceSemiStep> m_device;
    MatX m_device_q; ///< k x 3, q to and from the GPU
    double m_device_margin = 0.0; ///< the contact stage's candidate distance (m)
    /// The storage of the State whose values the GPU holds (the last step's result), or null
    /// after the host wrote it (state_written) or a step read it.
    const double* m_device_x = nullptr;
    const double* m_device_v = nullptr;
    const double* m_device_x_last = nullptr; ///< the last step's result's, kept
    bool m_host_current = true; ///< the last step's result is on the host too
    bool m_q_current = true; ///< the CPU global step's q is the GPU's
    bool m_planes_near = true; ///< a node is within the margin of a plane in this step

    /// Whether the GPU holds `state`'s values (a step from it needs no upload).
    bool holds_on_device(const State& state) const;
    void device_begin_step(const State& in, State& out);
    void device_iterate(int iteration);
    void device_finish_iteration(bool last);
    void measure_change(int iteration);
    void device_end_step();

    /// At iteration 0: whether this step accelerates, and its start.
    void begin_acceleration();
    /// After iterate()'s solve: the safeguard (redo the iteration from the plain iterate if the
    /// extrapolated one raised the energy, or the residual).
    void safeguard(int iteration);
    /// The safeguard's measure of the iterate the last iterate() read.
    double safeguard_measure();
};

// The three modes as compositions (see the file comment). Throw mat::Error if a part cannot be
// built (a factorization fails, a negative sample count).
PdSolver semi_reduced_solver(const Model& model, const SolverOptions& options = {});
PdSolver full_solver(const Model& model, const SolverOptions& options = {});
/// `samples`: tets in the local step, 0 = automatic (runtime/pd/hyper_reduced.hpp).
PdSolver hyper_reduced_solver(
    const Model& model, const SolverOptions& options = {}, Index samples = 0);
/// One of the three by kind.
std::unique_ptr<PdSolver> make_solver(SolverKind kind, const Model& model,
    const SolverOptions& options = {}, Index hyper_samples = 0);

} // namespace mat
