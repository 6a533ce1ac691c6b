#pragma once
// A scene's bodies stepped together (runtime/body.hpp: per body its immutable BodyModel, a
// solver, its State, its pinned regions with their prescribed motion). The bodies are built from
// the scene by load_bodies (runtime/scene/scene_bodies.hpp), where the bakes are read; this knows
// nothing of files (runtime/output/exporter.hpp writes frames).
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
#include <vector>

#include "runtime/body.hpp"
#include "runtime/collision/collision_world.hpp"
#include "runtime/pd/contact_stage.hpp"
#include "runtime/scene/scene.hpp"

namespace mat {

/// What the next steps read of one body that earlier steps wrote: restored into a simulation
/// of the same scene and bakes, the next steps are bitwise those of the run it was taken from
/// (runtime/output/checkpoint.hpp writes it; docs/mat-run.md, "Outputs and statistics").
struct BodySnapshot {
    MatX3 positions; ///< n x 3
    MatX3 velocities; ///< n x 3
    MatX3 pin_targets; ///< #pinned x 3: the body's last targets, and its solver's
    MatX3 solver_pin_targets;
    MatX q; ///< k x 3 reduced coordinates (a dynamic body of a reduced solver; else empty)
    std::vector<float> warm; ///< the local step's warm start (a dynamic body; else empty)
    ContactWarmStart contact; ///< the contact stage's forces of the last step
    bool asleep = false;
    int slow_steps = 0;
    bool moved = true;
};

struct SimulationSnapshot {
    long steps = 0;
    std::vector<BodySnapshot> bodies; ///< in the scene's object order
};

class Simulation {
public:
    /// Takes the scene's bodies (load_bodies(scene, ...), in the scene's object order) and sets
    /// up the collision world the scene asks for. The time step is the scene's, time.dt.
    Simulation(const Scene& scene, std::vector<Body> bodies);

    /// Advances every body by one time step dt.
    void step();

    double time() const { return m_steps * m_scene.time.dt; }
    long steps() const { return m_steps; }
    const Scene& scene() const { return m_scene; }
    std::vector<Body>& bodies() { return m_bodies; }
    const std::vector<Body>& bodies() const { return m_bodies; }
    /// The collision pipeline, or null when the scene turns collision off.
    const CollisionWorld* collision() const { return m_collision.get(); }
    /// Whether the coming steps' collision detection finds the intersecting triangle pairs
    /// (CollisionWorld::set_triangle_pairs; on by default).
    void set_triangle_pairs(bool on)
    {
        if (m_collision)
            m_collision->set_triangle_pairs(on);
    }
    /// Bodies asleep now.
    int num_sleeping() const;

    /// Brings every body's state to the host where its solver left it on a GPU (--device cuda;
    /// PdSolver::sync_state): before anything reads the states between steps. With collision
    /// detection on, each step does it itself.
    void sync_host();

    /// The state between two steps (runtime/simulation_snapshot.cpp; syncs the host first).
    SimulationSnapshot snapshot();
    /// Continues from a snapshot of a simulation of the same scene and bakes (before any step of
    /// this one). Throws mat::Error if a body's sizes differ.
    void restore(const SimulationSnapshot& snapshot);

private:
    /// Wakes the sleeping bodies whose box meets the box of a body that moves (a kinematic
    /// body, or an awake one whose last step was not slow); the bounds are the last update's.
    void wake_touched(std::vector<CollisionBodyState>& states);
    /// After a step: counts the body's slow steps and puts it to sleep after enough.
    void update_sleep(Body& body, bool pins_moved);
    void move_kinematic(Body& body, double time);
    double motion_bound(const Body& body) const;
    /// The collision world's contacts at the start of the step (wakes the touched sleepers).
    const BodyContacts& detect_contacts();
    /// Halfway through a step's iterations (solver.detect_in_step): the contacts found again at
    /// the iterate, and the contact stage begun again with them (its forces kept by key).
    void detect_in_step(const std::vector<ContactBodyState>& views, const BodyContacts& start);
    /// Steps the awake dynamic bodies together with the contact stage.
    void step_bodies(const BodyContacts& contacts, const std::vector<char>& pins_moved);

    const Scene& m_scene;
    std::vector<Body> m_bodies;
    // Per-step workspace (kept to allocate nothing per step).
    std::vector<CollisionBodyState> m_states;
    /// detect_in_step's contacts: those found at the iterate, then those of the step's start
    /// that the iterate's search no longer finds; and a copy of the start's.
    BodyContacts m_step_contacts, m_start_contacts;
    std::vector<std::uint64_t> m_contact_ids; ///< BodyContacts::append_missing's workspace
    std::vector<char> m_pins_moved;
    std::vector<std::size_t> m_movers;
    std::unique_ptr<CollisionWorld> m_collision;
    std::unique_ptr<ContactStage> m_contact_stage;
    BodyContacts m_no_contacts;
    std::vector<ContactBodyState> m_contact_views;
    std::vector<std::size_t> m_stepped;
    long m_steps = 0;
};

} // namespace mat
