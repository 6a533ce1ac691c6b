#include "runtime/scene/pin_motion.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"

namespace mat {

Mat3 rotation_from_euler_degrees(const Vec3& angles)
{
    const Vec3 radians = angles * (M_PI / 180.0);
    return (Eigen::AngleAxisd(radians.z(), Vec3::UnitZ())
        * Eigen::AngleAxisd(radians.y(), Vec3::UnitY())
        * Eigen::AngleAxisd(radians.x(), Vec3::UnitX()))
        .toRotationMatrix();
}

PinTransform pin_motion_at(const PinRegion& region, double time, const Vec3& centroid)
{
    return keyframe_motion_at(region.motion, time, centroid);
}

PinTransform kinematic_motion_at(const ObjectSettings& object, double time, const Vec3& centre)
{
    if (!object.keyframes.empty())
        return keyframe_motion_at(object.keyframes, time, centre);
    PinTransform transform;
    const double angle = object.angular_velocity.norm() * time;
    if (angle != 0.0)
        transform.rotation
            = Eigen::AngleAxisd(angle, object.angular_velocity.normalized()).toRotationMatrix();
    // x -> R (x - c) + c + v t
    transform.translation = centre + object.velocity * time - transform.rotation * centre;
    return transform;
}

PinTransform keyframe_motion_at(
    const std::vector<PinKeyframe>& keys, double time, const Vec3& centroid)
{
    if (keys.empty())
        return {};

    Vec3 translation;
    Vec3 angles;
    if (!(time > keys.front().time)) { // also a NaN time: hold the first keyframe
        translation = keys.front().translation;
        angles = keys.front().rotation_degrees;
    } else if (time >= keys.back().time) {
        translation = keys.back().translation;
        angles = keys.back().rotation_degrees;
    } else {
        // The first keyframe later than `time`; keys[next - 1].time < time < keys[next].time.
        const auto after = std::upper_bound(keys.begin(), keys.end(), time,
            [](double t, const PinKeyframe& key) { return t < key.time; });
        const PinKeyframe& k1 = *after;
        const PinKeyframe& k0 = *(after - 1);
        MAT_CHECK(k1.time > k0.time, "keyframe times must be strictly increasing");
        const double alpha = (time - k0.time) / (k1.time - k0.time);
        translation = (1.0 - alpha) * k0.translation + alpha * k1.translation;
        angles = (1.0 - alpha) * k0.rotation_degrees + alpha * k1.rotation_degrees;
    }

    PinTransform transform;
    transform.rotation = rotation_from_euler_degrees(angles);
    // x -> R (x - c) + c + t
    transform.translation = centroid + translation - transform.rotation * centroid;
    return transform;
}

MatX3 apply_pin_transform(const PinTransform& transform, const Eigen::Ref<const MatX3>& positions)
{
    MatX3 moved = positions * transform.rotation.transpose();
    moved.rowwise() += transform.translation.transpose();
    return moved;
}

} // namespace mat
