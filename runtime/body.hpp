#pragma once
// One body of a run: its immutable BodyModel (runtime/body_model.hpp, built once from its bake)
// and what changes as it moves (state, solver workspace, pins, sleep). Bodies are built from a
// scene by runtime/scene/scene_bodies.hpp, stepped by runtime/simulation.hpp, written by
// runtime/output/exporter.hpp and measured by runtime/measures/.

#include <memory>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/body_model.hpp"
#include "runtime/pd/solver.hpp"
#include "runtime/scene/scene.hpp"
#include "runtime/state.hpp"

namespace mat {

/// One pinned region of a body: its nodes (indices into the model's pinned list and the mesh).
struct PinGroup {
    const PinRegion* region = nullptr;
    std::vector<int> nodes; ///< tet-mesh nodes (each node in one group only)
    std::vector<int> slots; ///< their rows in the model's pin list
    Vec3 centroid = Vec3::Zero(); ///< rest centroid, bake coordinates
};

struct Body {
    std::string name;
    std::shared_ptr<const BodyModel> model;
    std::unique_ptr<PdSolver> solver; ///< (a static or kinematic body's is never stepped)
    State state;
    State next;
    Mat3 rotation = Mat3::Identity(); ///< placement
    Vec3 translation = Vec3::Zero();
    std::vector<PinGroup> pins;
    MatX3 pin_targets; ///< #pinned x 3, workspace
    /// Not stepped by a solver (a static or a kinematic object): a mesh collider for the others.
    bool is_static = false;
    bool is_kinematic = false; ///< moves rigidly as prescribed (then is_static too)
    const ObjectSettings* object = nullptr; ///< its scene entry
    MatX3 placed_rest; ///< n x 3 placed rest positions (kinematic bodies only)
    Vec3 placed_centre = Vec3::Zero(); ///< placed centre of mass
    /// Sleeping (scene keys solver.sleep_speed, solver.sleep_steps): a dynamic body that is not
    /// stepped; its velocities are zero and its positions, collision bounds and surface stay.
    bool asleep = false;
    int slow_steps = 0; ///< consecutive steps with every node slower than sleep_speed
    double sleep_speed = 0.0; ///< m/s: solver.sleep_speed x the rest diagonal (0: never sleeps)
    /// Moved since the collision world last updated its bounds (else they are reused).
    bool moved = true;
};

/// Sets the body's pin targets at `time` (its regions' motion, placed) and hands them to its
/// solver; whether any moved.
bool update_pin_targets(Body& body, double time);

} // namespace mat
