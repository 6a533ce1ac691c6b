// Kinematic objects in scene files: motion "kinematic" with keyframes or a constant velocity and
// angular velocity, the errors for keys that do not fit, and the prescribed rigid motion.

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "runtime/scene/pin_motion.hpp"
#include "runtime/scene/scene.hpp"

namespace mat {
namespace {

    constexpr double tolerance = 1e-12;

    Scene parse(const std::string& text)
    {
        SceneOptions options;
        options.check_files = false;
        return parse_scene(text, "scene.json", options);
    }

    std::string error_of(const std::string& text)
    {
        try {
            parse(text);
        } catch (const Error& e) {
            return e.what();
        }
        return "(no error)";
    }

    /// A scene whose single object has `object_keys` added after its bake.
    std::string with_object(const std::string& object_keys)
    {
        return R"({"objects": [{"bake": "a.h5", )" + object_keys + "}]}";
    }

    TEST(KinematicScene, KeyframesAreStored)
    {
        const Scene scene = parse(with_object(R"("motion": "kinematic", "keyframes": [
            {"time": 0}, {"time": 0.5, "translation": [1, 2, 3], "rotation_degrees": [0, 90, 0]}])"));
        const ObjectSettings& object = scene.objects[0];
        EXPECT_EQ(object.motion, ObjectMotion::kinematic);
        ASSERT_EQ(object.keyframes.size(), 2u);
        EXPECT_EQ(object.keyframes[0].translation, Vec3::Zero());
        EXPECT_EQ(object.keyframes[1].time, 0.5);
        EXPECT_EQ(object.keyframes[1].translation, Vec3(1, 2, 3));
        EXPECT_EQ(object.keyframes[1].rotation_degrees, Vec3(0, 90, 0));
    }

    TEST(KinematicScene, ConstantVelocityNeedsNoKeyframes)
    {
        const Scene scene = parse(with_object(
            R"("motion": "kinematic", "velocity": [1, 0, 0], "angular_velocity": [0, 0, 2])"));
        EXPECT_TRUE(scene.objects[0].keyframes.empty());
        EXPECT_EQ(scene.objects[0].velocity, Vec3(1, 0, 0));
    }

    TEST(KinematicScene, BadValuesNameTheKey)
    {
        EXPECT_EQ(error_of(with_object(R"("motion": "flying")")),
            "scene.json: objects[0].motion: \"flying\" is not one of dynamic, static, kinematic");
        EXPECT_EQ(error_of(with_object(R"("keyframes": [{"time": 0}])")),
            "scene.json: objects[0].keyframes: only a kinematic object has keyframes (motion is "
            "\"dynamic\")");
        EXPECT_EQ(error_of(with_object(R"("motion": "static", "keyframes": [{"time": 0}])")),
            "scene.json: objects[0].keyframes: only a kinematic object has keyframes (motion is "
            "\"static\")");
        EXPECT_EQ(error_of(with_object(R"("motion": "kinematic", "pins": [{"nodes": [0]}])")),
            "scene.json: objects[0].pins: a kinematic object moves rigidly as prescribed: it "
            "cannot have pins");
        EXPECT_EQ(
            error_of(with_object(
                R"("motion": "kinematic", "velocity": [1, 0, 0], "keyframes": [{"time": 0}])")),
            "scene.json: objects[0].velocity: a kinematic object with keyframes moves by them: "
            "give keyframes or velocity and angular_velocity, not both");
        EXPECT_EQ(error_of(with_object(R"("motion": "kinematic",
            "keyframes": [{"time": 0}, {"time": 1}, {"time": 1}])")),
            "scene.json: objects[0].keyframes[2].time: 1 is not after the previous keyframe's "
            "time 1");
        EXPECT_EQ(error_of(with_object(R"("motion": "kinematic", "keyframes": [{"time": -1}])")),
            "scene.json: objects[0].keyframes[0].time: -1 is out of range: must be >= 0");
        EXPECT_EQ(error_of(with_object(R"("motion": "kinematic", "keyframes": [{}])")),
            "scene.json: objects[0].keyframes[0].time: missing required key");
        EXPECT_EQ(error_of(with_object(R"("motion": "kinematic", "keyframes": [{"time": 0,
            "speed": 1}])")),
            "scene.json: objects[0].keyframes[0].speed: unknown key (expected time, translation, "
            "rotation_degrees)");
    }

    TEST(KinematicScene, TheReferenceDocumentsTheKeys)
    {
        bool keyframes = false, time = false;
        for (const SceneKeyInfo& key : scene_keys()) {
            keyframes = keyframes || (key.section == "objects[]" && key.key == "keyframes");
            time = time || (key.section == "objects[].keyframes[]" && key.key == "time");
        }
        EXPECT_TRUE(keyframes);
        EXPECT_TRUE(time);
    }

    TEST(KinematicMotion, ConstantVelocityAndSpinAboutTheCentre)
    {
        ObjectSettings object;
        object.velocity = Vec3(1, -2, 0.5);
        object.angular_velocity = Vec3(0, 0, 3);
        const Vec3 centre(0.5, 1, -1);
        const double t = 0.7;
        const PinTransform m = kinematic_motion_at(object, t, centre);
        // The centre moves with the velocity; a point at the centre + x turns by 3 t about z.
        EXPECT_TRUE(m.apply(centre).isApprox(centre + t * object.velocity, tolerance));
        const Vec3 turned = m.apply(centre + Vec3::UnitX()) - m.apply(centre);
        EXPECT_NEAR(turned.x(), std::cos(3 * t), tolerance);
        EXPECT_NEAR(turned.y(), std::sin(3 * t), tolerance);
        EXPECT_NEAR(turned.z(), 0.0, tolerance);
        // At rest: the identity.
        const PinTransform still = kinematic_motion_at(ObjectSettings {}, t, centre);
        EXPECT_TRUE(still.rotation.isIdentity(0.0));
        EXPECT_TRUE(still.translation.isZero(0.0));
    }

    TEST(KinematicMotion, KeyframesRotateAboutThePlacedCentre)
    {
        ObjectSettings object;
        object.keyframes.resize(2);
        object.keyframes[1].time = 2.0;
        object.keyframes[1].translation = Vec3(2, 0, 0);
        object.keyframes[1].rotation_degrees = Vec3(0, 0, 90);
        const Vec3 centre(1, 1, 0);
        const PinTransform half = kinematic_motion_at(object, 1.0, centre);
        EXPECT_TRUE(half.apply(centre).isApprox(centre + Vec3(1, 0, 0), tolerance));
        const Vec3 arm = half.apply(centre + Vec3::UnitX()) - half.apply(centre);
        EXPECT_TRUE(arm.isApprox(Vec3(std::sqrt(0.5), std::sqrt(0.5), 0), tolerance));
        // After the last keyframe it holds; velocity keys are ignored with keyframes.
        object.velocity = Vec3(5, 5, 5);
        const PinTransform late = kinematic_motion_at(object, 10.0, centre);
        EXPECT_TRUE(late.apply(centre).isApprox(centre + Vec3(2, 0, 0), tolerance));
    }

} // namespace
} // namespace mat
