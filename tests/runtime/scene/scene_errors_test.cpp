// Bad scene files: each class of mistake gives one mat::Error line that names the file and the
// key path (or the line and column of a JSON syntax error) and says what is wrong.

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "runtime/scene/scene.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    namespace fs = std::filesystem;

    /// The message parse_scene throws for `text` (named "scene.json", bake files not checked).
    std::string error_of(const std::string& text)
    {
        SceneOptions options;
        options.check_files = false;
        try {
            parse_scene(text, "scene.json", options);
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

    /// A scene with a valid object and `keys` at the top level.
    std::string with_top(const std::string& keys)
    {
        return R"({"objects": [{"bake": "a.h5"}], )" + keys + "}";
    }

    TEST(SceneErrors, OutOfRange)
    {
        EXPECT_EQ(error_of(R"({"objects": [{"bake": "a.h5"},
            {"bake": "b.h5", "material": {"poisson_ratio": 0.7}}]})"),
            "scene.json: objects[1].material.poisson_ratio: 0.7 is out of range [0, 0.5)");
        EXPECT_EQ(error_of(with_top(R"("time": {"dt": 0})")),
            "scene.json: time.dt: 0 is out of range: must be > 0");
        EXPECT_EQ(error_of(with_top(R"("time": {"frames": 0})")),
            "scene.json: time.frames: 0 is out of range: must be >= 1");
        EXPECT_EQ(error_of(with_top(R"("solver": {"damping": 1})")),
            "scene.json: solver.damping: 1 is out of range [0, 1)");
        EXPECT_EQ(error_of(with_top(R"("solver": {"anderson_window": 17})")),
            "scene.json: solver.anderson_window: 17 is out of range [1, 16]");
        EXPECT_EQ(error_of(with_top(R"("solver": {"anderson_window": 0})")),
            "scene.json: solver.anderson_window: 0 is out of range [1, 16]");
        EXPECT_EQ(error_of(with_object(R"("material": {"density": -2})")),
            "scene.json: objects[0].material.density: -2 is out of range: must be > 0");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"nodes": [0, -1]}])")),
            "scene.json: objects[0].pins[0].nodes[1]: -1 is out of range: must be >= 0");
        EXPECT_EQ(
            error_of(with_object(R"("pins": [{"sphere": {"center": [0,0,0], "radius": 0}}])")),
            "scene.json: objects[0].pins[0].sphere.radius: 0 is out of range: must be > 0");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"box": {"min": [0,0,0], "max": [1,1,1]},
            "motion": [{"time": -1}]}])")),
            "scene.json: objects[0].pins[0].motion[0].time: -1 is out of range: must be >= 0");
        EXPECT_EQ(error_of(with_top(R"("colliders": [{"type": "plane", "friction": -0.1}])")),
            "scene.json: colliders[0].friction: -0.1 is out of range: must be >= 0");
        EXPECT_EQ(error_of(with_object(R"("material": {"strain_limits": [1.1, 2]})")),
            "scene.json: objects[0].material.strain_limits: [1.1, 2] must satisfy 0 <= min <= 1 "
            "<= max");
        EXPECT_EQ(error_of(with_top(R"("colliders": [{"type": "plane", "normal": [0, 0, 0]}])")),
            "scene.json: colliders[0].normal: must not be the zero vector");
    }

    TEST(SceneErrors, UnknownKey)
    {
        EXPECT_EQ(error_of(with_object(R"("pins": [{"nodes": [1]}, {"nodes": [2]},
            {"box": {"mni": [0, 0, 0], "max": [1, 1, 1]}}])")),
            "scene.json: objects[0].pins[2].box.mni: unknown key (expected min, max)");
        EXPECT_EQ(error_of(with_top(R"("time": {"step": 0.1})")),
            "scene.json: time.step: unknown key (expected dt, frames, duration, fps, iterations, "
            "tolerance)");
        EXPECT_EQ(error_of(with_top(R"("camera": {})")),
            "scene.json: camera: unknown key (expected time, gravity, solver, objects, colliders, "
            "output)");
    }

    TEST(SceneErrors, WrongType)
    {
        EXPECT_EQ(error_of(with_top(R"("time": {"dt": "fast"})")),
            "scene.json: time.dt: expected a number, got the string \"fast\"");
        EXPECT_EQ(error_of(with_top(R"("time": {"frames": 2.5})")),
            "scene.json: time.frames: 2.5 is not an integer");
        EXPECT_EQ(error_of(with_top(R"("time": {"iterations": 1e12})")),
            "scene.json: time.iterations: 1000000000000 is too large for an integer");
        EXPECT_EQ(error_of(with_top(R"("gravity": [0, -9.81])")),
            "scene.json: gravity: expected [x, y, z] (a list of 3 numbers), got a list of 2 "
            "elements");
        EXPECT_EQ(error_of(with_top(R"("gravity": [0, true, 0])")),
            "scene.json: gravity[1]: expected a number, got the boolean true");
        EXPECT_EQ(error_of(with_top(R"("solver": [])")),
            "scene.json: solver: expected a section (JSON object), got a list of 0 elements");
        EXPECT_EQ(error_of(R"({"objects": {"bake": "a.h5"}})"),
            "scene.json: objects: expected a list of sections, got a section (JSON object)");
        EXPECT_EQ(error_of(R"({"objects": ["a.h5"]})"),
            "scene.json: objects[0]: expected a section (JSON object), got the string \"a.h5\"");
        EXPECT_EQ(error_of(R"({"objects": [{"bake": 3}]})"),
            "scene.json: objects[0].bake: expected a path (string), got the number 3");
        EXPECT_EQ(error_of(with_object(R"("name": null)")),
            "scene.json: objects[0].name: expected a string, got null");
        EXPECT_EQ(error_of(with_top(R"("output": {"format": ["obj", "stl"]})")),
            "scene.json: output.format[1]: \"stl\" is not one of obj, ply, vtu, h5");
        EXPECT_EQ(error_of(with_top(R"("output": {"format": "gltf"})")),
            "scene.json: output.format: \"gltf\" is not one of obj, ply, vtu, h5");
        EXPECT_EQ(error_of(with_top(R"("output": {"fields": ["velocity", "velocity"]})")),
            "scene.json: output.fields[1]: \"velocity\" is listed twice");
        EXPECT_EQ(error_of(with_top(R"("colliders": [{"type": "sphere"}])")),
            "scene.json: colliders[0].type: \"sphere\" is not one of plane");
        EXPECT_EQ(error_of(with_top(R"("solver": {"acceleration": "chebyshev"})")),
            "scene.json: solver.acceleration: \"chebyshev\" is not one of none, anderson");
        EXPECT_EQ(error_of("[1, 2]"),
            "scene.json: expected a JSON object at the top level, got a list of 2 elements");
    }

    TEST(SceneErrors, MissingOrEmpty)
    {
        EXPECT_EQ(error_of("{}"), "scene.json: objects: missing required key");
        EXPECT_EQ(error_of(R"({"objects": []})"),
            "scene.json: objects: expected at least 1 element, got 0");
        EXPECT_EQ(error_of(R"({"objects": [{"bake": "a.h5"}, {"name": "b"}]})"),
            "scene.json: objects[1].bake: missing required key");
        EXPECT_EQ(error_of(R"({"objects": [{"bake": ""}]})"),
            "scene.json: objects[0].bake: the path is empty");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"box": {"min": [0, 0, 0]}}])")),
            "scene.json: objects[0].pins[0].box.max: missing required key");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"motion": [{"translation": [0, 1, 0]}],
            "nodes": [1]}])")),
            "scene.json: objects[0].pins[0].motion[0].time: missing required key");
        EXPECT_EQ(error_of(with_top(R"("colliders": [{"normal": [0, 1, 0]}])")),
            "scene.json: colliders[0].type: missing required key");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"nodes": []}])")),
            "scene.json: objects[0].pins[0].nodes: expected at least 1 element, got 0");
        EXPECT_EQ(error_of(with_object(R"("name": "")")),
            "scene.json: objects[0].name: must not be empty");
    }

    TEST(SceneErrors, InconsistentKeys)
    {
        EXPECT_EQ(error_of(with_object(R"("pins": [{"nodes": [1]}, {}])")),
            "scene.json: objects[0].pins[1]: a pin region needs exactly one of box, sphere, "
            "nodes; got none");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"nodes": [1],
            "sphere": {"center": [0, 0, 0], "radius": 1}}])")),
            "scene.json: objects[0].pins[0]: a pin region needs exactly one of box, sphere, "
            "nodes; got sphere and nodes");
        EXPECT_EQ(
            error_of(with_object(R"("pins": [{"box": {"min": [0, 2, 0], "max": [1, 1, 1]}}])")),
            "scene.json: objects[0].pins[0].box.max: 1 is below min 2 along y");
        EXPECT_EQ(error_of(with_object(R"("pins": [{"nodes": [1],
            "motion": [{"time": 0}, {"time": 1}, {"time": 1}]}])")),
            "scene.json: objects[0].pins[0].motion[2].time: 1 is not after the previous "
            "keyframe's time 1");
        EXPECT_EQ(error_of(R"({"objects": [{"name": "a", "bake": "a.h5"}, {"bake": "b.h5"},
            {"name": "a", "bake": "c.h5"}]})"),
            "scene.json: objects[2].name: \"a\" is already the name of objects[0]");
        // A default name counts too.
        EXPECT_EQ(
            error_of(R"({"objects": [{"bake": "a.h5"}, {"name": "object0", "bake": "b.h5"}]})"),
            "scene.json: objects[1].name: \"object0\" is already the name of objects[0]");
    }

    TEST(SceneErrors, InconsistentTimeSettings)
    {
        EXPECT_EQ(error_of(with_top(R"("time": {"frames": 10, "duration": 1})")),
            "scene.json: time.duration: cannot be combined with time.frames (give one of them)");
        EXPECT_EQ(error_of(with_top(R"("time": {"fps": 30}, "output": {"every": 1})")),
            "scene.json: time.fps: cannot be combined with output.every (give one of them)");
        EXPECT_EQ(error_of(with_top(R"("time": {"dt": 0.01, "fps": 40})")),
            "scene.json: time.fps: 1 / (fps * dt) = 2.5 steps per frame is not a whole number (to "
            "1e-6 relative); choose fps and dt so that it is");
        EXPECT_EQ(error_of(with_top(R"("time": {"dt": 0.01, "fps": 250})")),
            "scene.json: time.fps: 250 with dt 0.01 gives 0.4 steps per frame; need at least 1");
        EXPECT_EQ(error_of(with_top(R"("time": {"dt": 0.01, "duration": 0.004})")),
            "scene.json: time.duration: 0.004 s is less than half a frame interval (0.01 s)");
    }

    TEST(SceneErrors, JsonSyntaxNamesLineAndColumn)
    {
        const std::string message = error_of("{\n  \"objects\": [\n    {\"bake\": \"a.h5\",,}\n]}");
        EXPECT_EQ(message.rfind("scene.json: line 3, column 21: ", 0), 0u) << message;
        EXPECT_NE(message.find("syntax error"), std::string::npos) << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << message;
        EXPECT_EQ(message.find("json.exception"), std::string::npos) << message;

        EXPECT_EQ(error_of("").rfind("scene.json: line 1, column 1: ", 0), 0u);
        const std::string overflow = error_of("{\"gravity\": [0,\n 1e999, 0]}");
        EXPECT_EQ(overflow.rfind("scene.json: line 2, column 2: ", 0), 0u) << overflow;
        EXPECT_NE(overflow.find("1e999"), std::string::npos) << overflow;
    }

    TEST(SceneErrors, DuplicateKey)
    {
        EXPECT_EQ(error_of(R"({"objects": [{"bake": "a.h5"},
            {"bake": "b.h5", "material": {"density": 1, "density": 2}}]})"),
            "scene.json: objects[1].material.density: duplicate key");
        EXPECT_EQ(error_of(R"({"time": {}, "objects": [{"bake": "a.h5"}], "time": {}})"),
            "scene.json: time: duplicate key");
        EXPECT_EQ(error_of(R"({"objects": [{"bake": "a.h5", "pins": [{"nodes": [[1], 2]},
            {"nodes": [1], "nodes": [2]}]}]})"),
            "scene.json: objects[0].pins[1].nodes: duplicate key");
    }

    using SceneFileErrors = test::ScratchDirTest;

    TEST_F(SceneFileErrors, MissingBakeNamesTheKeyAndThePathTried)
    {
        write_text("a.h5", "");
        fs::create_directories(dir() / "folder.h5");
        const std::string scene = write_text(
            "scene.json", R"({"objects": [{"bake": "a.h5"}, {"bake": "bakes/../b.h5"}]})");
        const std::string expected
            = scene + ": objects[1].bake: file not found: " + (dir() / "b.h5").string();
        try {
            read_scene(scene);
            ADD_FAILURE() << "no error";
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()), expected);
        }
        const std::string folder
            = write_text("folder.json", R"({"objects": [{"bake": "folder.h5"}]})");
        test::expect_error_containing([&] { read_scene(folder); },
            { folder + ": objects[0].bake: ", (dir() / "folder.h5").string(), "is a directory" });
        test::expect_error_containing(
            [&] { read_scene(path("absent.json")); }, { path("absent.json"), "cannot open" });
    }

} // namespace
} // namespace mat
