#pragma once
// A scene's bodies, built from their bakes: the edge where bakes are read (formats/bake_io).
// Per object: its bake (each file read once, however many objects share it), its BodyModel
// (the object's material, the scene's dt and volume tolerance, its pinned nodes), its solver
// (the kind asked for, with the scene's solver settings), and its initial state: the placed rest
// positions, moving with the object's velocity and angular velocity about its centre of mass
// (pinned nodes at rest; a static body at rest; a kinematic one at its motion's start).
// Placement: a body's bake coordinates X map to the world by x = R X + t (rotation_degrees,
// position); the model stays in bake coordinates (runtime/simulation.hpp).

#include <vector>

#include "runtime/body.hpp"
#include "runtime/scene/scene.hpp"

namespace mat {

/// Builds every object of `scene` (which must outlive the bodies: they point at its entries).
/// Throws mat::Error naming the bake file for a bake that cannot be read, and the scene key for
/// a pin region that selects no node or a node index out of range.
std::vector<Body> load_bodies(const Scene& scene, SolverKind solver);

} // namespace mat
