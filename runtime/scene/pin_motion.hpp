#pragma once
// Prescribed rigid motion of pinned regions, and the Euler-angle convention of scene files.
//
// Euler angles (scene keys rotation_degrees) are XYZ in degrees: rotate about x, then about y,
// then about z (all fixed axes), i.e. R = Rz(c) Ry(b) Rx(a).
//
// A pin region's motion is a list of keyframes (time, translation, rotation_degrees). Between two
// keyframes translation and Euler angles are interpolated linearly (not a geodesic of rotations:
// fine for the modest per-segment rotations a scene uses; add keyframes for large ones). Before
// the first keyframe the first applies; after the last the last holds. A pinned node at rest
// position x goes to  R (x - c) + c + translation  with c the region's rest centroid.
//
// A kinematic object moves the same way, by its own keyframes, about its placed centre of mass c:
// a node at placed position x goes to  R(t) (x - c) + c + translation(t). Without keyframes it
// keeps its velocity v and angular velocity w:  R(t) = exp(t [w]x) (the rotation by |w| t about
// w), translation(t) = v t.

#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/scene/scene.hpp"

namespace mat {

/// The rigid map x -> rotation * x + translation.
struct PinTransform {
    Mat3 rotation = Mat3::Identity();
    Vec3 translation = Vec3::Zero();

    Vec3 apply(const Vec3& x) const { return rotation * x + translation; }
};

/// R = Rz(angles.z) Ry(angles.y) Rx(angles.x), angles in degrees.
Mat3 rotation_from_euler_degrees(const Vec3& angles);

/// The transform of `region`'s pinned nodes at `time` (s): the keyframes interpolated as above,
/// rotating about `centroid` (the region's rest centroid, bake coordinates). Identity without
/// keyframes.
PinTransform pin_motion_at(const PinRegion& region, double time, const Vec3& centroid);

/// Keyframes interpolated as above at `time` (s), rotating about `centroid`. Identity without
/// keyframes. `keys` must have strictly increasing times.
PinTransform keyframe_motion_at(
    const std::vector<PinKeyframe>& keys, double time, const Vec3& centroid);

/// The transform of a kinematic `object`'s placed nodes at `time` (s) as above; `centre` is its
/// placed centre of mass (world coordinates).
PinTransform kinematic_motion_at(const ObjectSettings& object, double time, const Vec3& centre);

/// Every row of `positions` (#P x 3) mapped by `transform`; returns #P x 3.
MatX3 apply_pin_transform(const PinTransform& transform, const Eigen::Ref<const MatX3>& positions);

} // namespace mat
