#pragma once
// A scene's bodies, built from their bakes and stepped together: per body an immutable Model,
// a solver, its State, its pinned regions with their prescribed motion, and the surface view the
// exporter reads. Knows nothing of output files (runtime/output/exporter.hpp writes frames).
//
// Placement: a body's bake coordinates X map to the world by x = R X + t (the object's
// rotation_degrees and position). The model stays in bake coordinates: PD energies are rotation
// invariant and the handle basis reproduces any affine map, so the placed rest state is exact.
// Pin regions select nodes by their bake coordinates; a pinned node's target at time t is the
// placement of its region's motion: R (M(t) X) + t_placement.
// A kinematic body is not simulated: each step first moves its nodes to their prescribed places
// at the end of the step (kinematic_motion_at of the placed rest positions), with velocities the
// step's displacement over dt; the collision world then sees it there, as a mesh collider (its
// nodes are constants of the others' contacts, and its motion over the step is part of them:
// friction acts on the others' motion relative to it; docs/method.md, "Contact").
// Each step: the collision world's contacts at the start of the step (detect_contacts), then
// every awake dynamic body's PD step in stages with one contact stage over all bodies between
// each iteration's global solves and positions (step_bodies).
// Sleeping: a dynamic body without moving pins whose nodes have all been slower than
// solver.sleep_speed x its rest diagonal per second for solver.sleep_steps consecutive steps
// falls asleep: its velocities are set to zero, its solver is no longer stepped, and the
// collision world treats it as a static collider that keeps its bounds. It wakes when its pins
// move or when its box meets the box of a moving body (a kinematic one, or an awake one whose
// last step was not slow); the boxes are those the collision world computes before the
// contacts, so a woken body takes part in the same step's contacts. Every decision reads only
// the bodies' states, in body order: runs do not depend on the thread count.

#include <memory>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/collision/collision_world.hpp"
#include "runtime/model.hpp"
#include "runtime/output/surface_view.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/state.hpp"

namespace mat {

enum class SolverKind { semi_reduced, full, hyper_reduced };

/// "semi", "full" or "hyper" -> SolverKind; throws mat::Error otherwise.
SolverKind parse_solver_kind(const std::string& name);

/// One pinned region of a body: its nodes (indices into the model's pinned list and the mesh).
struct PinGroup {
    const PinRegion* region = nullptr;
    std::vector<int> nodes; ///< tet-mesh nodes (each node in one group only)
    std::vector<int> slots; ///< their rows in the model's pin list
    Vec3 centroid = Vec3::Zero(); ///< rest centroid, bake coordinates
};

struct Body {
    std::string name;
    std::unique_ptr<Model> model;
    std::unique_ptr<PdSolver> solver;
    std::unique_ptr<SurfaceView> surface;
    State state;
    State next;
    Mat3 rotation = Mat3::Identity(); ///< placement
    Vec3 translation = Vec3::Zero();
    std::vector<PinGroup> pins;
    MatX3 pin_targets; ///< #pinned x 3, workspace
    Index num_handles = 0;
    /// Not stepped by a solver (a static or a kinematic object): a mesh collider for the others.
    bool is_static = false;
    bool is_kinematic = false; ///< moves rigidly as prescribed (then is_static too)
    const ObjectSettings* object = nullptr; ///< its scene entry
    MatX3 placed_rest; ///< n x 3 placed rest positions (kinematic bodies only)
    Vec3 placed_centre = Vec3::Zero(); ///< placed centre of mass
    /// For the collision check: the medial primitive enclosing each surface vertex  #Vs, and
    /// each primitive's spheres  #P x 3 (-1 unused).
    VecXi surface_primitive;
    MatX3i primitive_spheres;
    /// Sleeping (scene keys solver.sleep_speed, solver.sleep_steps): a dynamic body that is not
    /// stepped; its velocities are zero and its positions, collision bounds and surface stay.
    bool asleep = false;
    int slow_steps = 0; ///< consecutive steps with every node slower than sleep_speed
    double sleep_speed = 0.0; ///< m/s: solver.sleep_speed x the rest diagonal (0: never sleeps)
    /// Moved since the collision world last updated its bounds (else they are reused).
    bool moved = true;
};

class Simulation {
public:
    /// Reads every bake, builds the models and solvers. Throws mat::Error naming the scene key
    /// for a pin region that selects no node or a node index out of range, and the bake file
    /// for a bake that cannot be read.
    Simulation(const Scene& scene, SolverKind solver);

    /// Advances every body by one time step dt.
    void step();

    double time() const { return m_steps * m_scene.time.dt; }
    long steps() const { return m_steps; }
    const Scene& scene() const { return m_scene; }
    std::vector<Body>& bodies() { return m_bodies; }
    const std::vector<Body>& bodies() const { return m_bodies; }
    /// The collision pipeline, or null when the scene turns collision off.
    const CollisionWorld* collision() const { return m_collision.get(); }
    /// Bodies asleep now.
    int num_sleeping() const;

private:
    /// Sets the pin targets at `time`; whether any moved.
    bool update_pin_targets(Body& body, double time);
    /// Wakes the sleeping bodies whose box meets the box of a body that moves (a kinematic
    /// body, or an awake one whose last step was not slow); the bounds are the last update's.
    void wake_touched(std::vector<CollisionBodyState>& states);
    /// After a step: counts the body's slow steps and puts it to sleep after enough.
    void update_sleep(Body& body, bool pins_moved);
    void move_kinematic(Body& body, double time);
    double motion_bound(const Body& body) const;
    /// The collision world's contacts at the start of the step (wakes the touched sleepers).
    const BodyContacts& detect_contacts();
    /// Steps the awake dynamic bodies together with the contact stage.
    void step_bodies(const BodyContacts& contacts, const std::vector<char>& pins_moved);

    const Scene& m_scene;
    std::vector<Body> m_bodies;
    // Per-step workspace (kept to allocate nothing per step).
    std::vector<CollisionBodyState> m_states;
    std::vector<char> m_pins_moved;
    std::vector<std::size_t> m_movers;
    std::unique_ptr<CollisionWorld> m_collision;
    std::unique_ptr<ContactStage> m_contact_stage;
    BodyContacts m_no_contacts;
    std::vector<ContactBodyState> m_contact_views;
    std::vector<std::size_t> m_stepped;
    SolverKind m_solver_kind = SolverKind::semi_reduced;
    long m_steps = 0;
};

} // namespace mat
