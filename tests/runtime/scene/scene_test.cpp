// The scene file: the committed samples parse, defaults fill in, every key is stored where it
// belongs, bake paths resolve against the scene's directory, the time settings derive steps per
// frame and frame counts, and the Markdown reference lists every declared key.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "common/error.hpp"
#include "runtime/scene/scene.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    namespace fs = std::filesystem;

    SceneOptions no_file_check()
    {
        SceneOptions options;
        options.check_files = false;
        return options;
    }

    Scene parse(const std::string& text)
    {
        return parse_scene(text, "/scenes/demo/scene.json", no_file_check());
    }

    /// The sample scenes under samples/<name>/scene.json, by sample name.
    std::map<std::string, std::string> sample_scenes()
    {
        std::map<std::string, std::string> scenes;
        for (const auto& entry : fs::directory_iterator(MAT_SAMPLES_DIR)) {
            const fs::path scene = entry.path() / "scene.json";
            if (entry.is_directory() && fs::exists(scene))
                scenes[entry.path().filename().string()] = scene.string();
        }
        return scenes;
    }

    void expect_vec3(const Vec3& actual, double x, double y, double z)
    {
        EXPECT_DOUBLE_EQ(actual.x(), x);
        EXPECT_DOUBLE_EQ(actual.y(), y);
        EXPECT_DOUBLE_EQ(actual.z(), z);
    }

    TEST(SceneSamples, EverySampleSceneParses)
    {
        const auto scenes = sample_scenes();
        ASSERT_GE(scenes.size(), 4u);
        for (const auto& [name, path] : scenes) {
            SCOPED_TRACE(path);
            // The bakes are build products, absent from the source tree: paths are resolved
            // but not checked here (SceneFiles below checks them).
            const Scene scene = read_scene(path, no_file_check());
            EXPECT_EQ(scene.file, path);
            ASSERT_FALSE(scene.objects.empty());
            const fs::path bake = scene.objects[0].bake;
            EXPECT_TRUE(bake.is_absolute());
            // In the scene's directory, or another sample's (the collision scenes).
            EXPECT_EQ(bake.parent_path().parent_path(),
                fs::path(path).parent_path().parent_path().lexically_normal());
            EXPECT_EQ(bake.extension(), ".h5");
            EXPECT_NEAR(scene.time.dt, 1.0 / 30.0, 1e-9);
            EXPECT_GE(scene.frames, 60);
            EXPECT_EQ(scene.steps_per_frame, 1);
            expect_vec3(scene.gravity, 0, -9.81, 0);
            EXPECT_EQ(scene.output.formats, std::vector<OutputFormat> { OutputFormat::obj });
        }
        const Scene bar = read_scene(scenes.at("rounded_bar"), no_file_check());
        ASSERT_EQ(bar.objects[0].pins.size(), 1u);
        EXPECT_EQ(bar.objects[0].pins[0].kind, PinKind::box);
        EXPECT_DOUBLE_EQ(bar.objects[0].pins[0].box.max.x(), -0.35);
        EXPECT_TRUE(bar.colliders.empty());
        const Scene torus = read_scene(scenes.at("torus"), no_file_check());
        expect_vec3(torus.objects[0].angular_velocity, 0, 2, 0);
        expect_vec3(torus.objects[0].rotation_degrees, 60, 0, 0);
    }

    TEST(SceneDefaults, MinimalSceneGetsEveryDefault)
    {
        const Scene scene = parse(R"({"objects": [{"bake": "body.h5"}]})");
        EXPECT_EQ(scene.file, "/scenes/demo/scene.json");
        EXPECT_DOUBLE_EQ(scene.time.dt, 1.0 / 60.0);
        EXPECT_EQ(scene.time.frames, 60);
        EXPECT_FALSE(scene.time.duration);
        EXPECT_FALSE(scene.time.fps);
        EXPECT_EQ(scene.time.iterations, 10);
        EXPECT_EQ(scene.frames, 60);
        EXPECT_EQ(scene.steps_per_frame, 1);
        expect_vec3(scene.gravity, 0, -9.81, 0);
        EXPECT_EQ(scene.solver.damping, 0.0);
        EXPECT_EQ(scene.solver.volume_tolerance, 0.01);
        EXPECT_EQ(scene.solver.contact_margin, 0.01);
        EXPECT_EQ(scene.solver.reduced_pin_stiffness, 1.0);
        EXPECT_EQ(scene.solver.full_pin_stiffness, 1e8);
        ASSERT_EQ(scene.objects.size(), 1u);
        const ObjectSettings& object = scene.objects[0];
        EXPECT_EQ(object.name, "object0");
        EXPECT_EQ(object.bake, "/scenes/demo/body.h5");
        expect_vec3(object.position, 0, 0, 0);
        expect_vec3(object.rotation_degrees, 0, 0, 0);
        expect_vec3(object.velocity, 0, 0, 0);
        expect_vec3(object.angular_velocity, 0, 0, 0);
        EXPECT_EQ(object.material.youngs_modulus, 1e5);
        EXPECT_EQ(object.material.poisson_ratio, 0.3);
        EXPECT_EQ(object.material.density, 1000.0);
        EXPECT_FALSE(object.material.strain_limits);
        EXPECT_TRUE(object.pins.empty());
        EXPECT_TRUE(scene.colliders.empty());
        EXPECT_EQ(scene.output.formats, std::vector<OutputFormat> { OutputFormat::obj });
        EXPECT_EQ(scene.output.every, 1);
        EXPECT_TRUE(scene.output.fields.empty());
    }

    TEST(SceneDefaults, EveryKeyIsStoredWhereItBelongs)
    {
        const Scene scene = parse(R"({
          "time": {"dt": 0.01, "frames": 7, "iterations": 4},
          "gravity": [1, 2, 3],
          "solver": {"damping": 0.1, "volume_tolerance": 0.05, "contact_margin": 0.02,
                     "reduced_pin_stiffness": 3, "full_pin_stiffness": 4},
          "objects": [
            {"bake": "a.h5", "material": {"strain_limits": [0.9, 1.1]}},
            {"name": "second", "bake": "../b/b.h5", "position": [4, 5, 6],
             "rotation_degrees": [10, 20, 30], "velocity": [7, 8, 9],
             "angular_velocity": [0.1, 0.2, 0.3],
             "material": {"youngs_modulus": 2e6, "poisson_ratio": 0.45, "density": 500},
             "pins": [
               {"box": {"min": [0, 0, 0], "max": [1, 2, 3]}},
               {"sphere": {"center": [1, 1, 1], "radius": 0.5},
                "motion": [{"time": 0}, {"time": 1.5, "translation": [0, 1, 0],
                                          "rotation_degrees": [0, 90, 0]}]},
               {"nodes": [3, 1, 4]}
             ]}
          ],
          "colliders": [{"type": "plane", "point": [0, -1, 0], "normal": [0, 0, 2],
                         "friction": 0.25}],
          "output": {"format": ["vtu", "h5"], "every": 3, "fields": ["velocity", "stretch"]}
        })");
        EXPECT_EQ(scene.time.dt, 0.01);
        EXPECT_EQ(scene.frames, 7);
        EXPECT_EQ(scene.time.iterations, 4);
        expect_vec3(scene.gravity, 1, 2, 3);
        EXPECT_EQ(scene.solver.damping, 0.1);
        EXPECT_EQ(scene.solver.volume_tolerance, 0.05);
        EXPECT_EQ(scene.solver.contact_margin, 0.02);
        EXPECT_EQ(scene.solver.reduced_pin_stiffness, 3.0);
        EXPECT_EQ(scene.solver.full_pin_stiffness, 4.0);
        ASSERT_EQ(scene.objects.size(), 2u);
        EXPECT_EQ(scene.objects[0].name, "object0");
        ASSERT_TRUE(scene.objects[0].material.strain_limits);
        EXPECT_EQ(*scene.objects[0].material.strain_limits, Vec2(0.9, 1.1));

        const ObjectSettings& object = scene.objects[1];
        EXPECT_EQ(object.name, "second");
        EXPECT_EQ(object.bake, "/scenes/b/b.h5");
        expect_vec3(object.position, 4, 5, 6);
        expect_vec3(object.rotation_degrees, 10, 20, 30);
        expect_vec3(object.velocity, 7, 8, 9);
        expect_vec3(object.angular_velocity, 0.1, 0.2, 0.3);
        EXPECT_EQ(object.material.youngs_modulus, 2e6);
        EXPECT_EQ(object.material.poisson_ratio, 0.45);
        EXPECT_EQ(object.material.density, 500.0);
        ASSERT_EQ(object.pins.size(), 3u);
        EXPECT_EQ(object.pins[0].kind, PinKind::box);
        expect_vec3(object.pins[0].box.max, 1, 2, 3);
        EXPECT_TRUE(object.pins[0].motion.empty());
        EXPECT_EQ(object.pins[1].kind, PinKind::sphere);
        expect_vec3(object.pins[1].sphere.center, 1, 1, 1);
        EXPECT_EQ(object.pins[1].sphere.radius, 0.5);
        ASSERT_EQ(object.pins[1].motion.size(), 2u);
        EXPECT_EQ(object.pins[1].motion[1].time, 1.5);
        expect_vec3(object.pins[1].motion[0].translation, 0, 0, 0);
        expect_vec3(object.pins[1].motion[1].translation, 0, 1, 0);
        expect_vec3(object.pins[1].motion[1].rotation_degrees, 0, 90, 0);
        EXPECT_EQ(object.pins[2].kind, PinKind::nodes);
        EXPECT_EQ(object.pins[2].nodes, (std::vector<int> { 3, 1, 4 }));

        ASSERT_EQ(scene.colliders.size(), 1u);
        EXPECT_EQ(scene.colliders[0].type, ColliderType::plane);
        expect_vec3(scene.colliders[0].point, 0, -1, 0);
        expect_vec3(scene.colliders[0].normal, 0, 0, 1); // normalized
        EXPECT_EQ(scene.colliders[0].friction, 0.25);
        EXPECT_EQ(scene.output.formats,
            (std::vector<OutputFormat> { OutputFormat::vtu, OutputFormat::h5 }));
        EXPECT_EQ(scene.output.every, 3);
        EXPECT_EQ(scene.steps_per_frame, 3);
        EXPECT_EQ(scene.output.fields,
            (std::vector<OutputField> { OutputField::velocity, OutputField::stretch }));
    }

    TEST(SceneDefaults, CollidersNormalsOfExtremeMagnitudeBecomeUnit)
    {
        // Found by fuzzing: [1e300, 1e300, 0] normalized to the zero vector (its squared norm
        // overflowed) and [1e-200, 0, 0] was refused as zero (its squared norm underflowed).
        const Scene scene = parse(R"({"objects": [{"bake": "/abs/body.h5"}], "colliders": [
            {"type": "plane", "normal": [1e300, 1e300, 0]},
            {"type": "plane", "normal": [1e-200, 0, 0]}]})");
        ASSERT_EQ(scene.colliders.size(), 2u);
        expect_vec3(scene.colliders[0].normal, std::sqrt(0.5), std::sqrt(0.5), 0);
        expect_vec3(scene.colliders[1].normal, 1, 0, 0);
    }

    TEST(SceneDefaults, IntegralNumbersAreIntegersAndAFormatMayBeOneString)
    {
        const Scene scene = parse(R"({"time": {"frames": 12.0, "iterations": 2e1},
            "objects": [{"bake": "/abs/./x/../body.h5"}], "output": {"format": "ply"}})");
        EXPECT_EQ(scene.frames, 12);
        EXPECT_EQ(scene.time.iterations, 20);
        EXPECT_EQ(scene.objects[0].bake, "/abs/body.h5"); // absolute paths are kept, normalized
        EXPECT_EQ(scene.output.formats, std::vector<OutputFormat> { OutputFormat::ply });
    }

    TEST(SceneTime, FpsSetsStepsPerFrame)
    {
        const Scene scene = parse(R"({"time": {"dt": 0.005, "fps": 50, "frames": 10},
            "objects": [{"bake": "a.h5"}]})");
        EXPECT_EQ(scene.steps_per_frame, 4);
        EXPECT_EQ(scene.output.every, 4);
        EXPECT_EQ(scene.frames, 10);
        EXPECT_DOUBLE_EQ(scene.frame_interval(), 0.02);
        // 1 / (30 * (1/120)) = 4 up to rounding of the decimal dt.
        EXPECT_EQ(parse(R"({"time": {"dt": 0.00833333333333, "fps": 30},
            "objects": [{"bake": "a.h5"}]})")
                      .steps_per_frame,
            4);
    }

    TEST(SceneTime, DurationSetsFrames)
    {
        // every = 2 steps of 0.01 s: 50 frames per second, 1.234 s -> round(61.7) = 62 frames.
        const Scene with_every = parse(R"({"time": {"dt": 0.01, "duration": 1.234},
            "output": {"every": 2}, "objects": [{"bake": "a.h5"}]})");
        EXPECT_EQ(with_every.steps_per_frame, 2);
        EXPECT_EQ(with_every.frames, 62);
        EXPECT_EQ(with_every.time.frames, 62);
        // fps = 25 with dt = 0.01: 4 steps per frame; 2 s -> 50 frames.
        const Scene with_fps = parse(R"({"time": {"dt": 0.01, "fps": 25, "duration": 2},
            "objects": [{"bake": "a.h5"}]})");
        EXPECT_EQ(with_fps.steps_per_frame, 4);
        EXPECT_EQ(with_fps.frames, 50);
        ASSERT_TRUE(with_fps.time.duration);
        EXPECT_EQ(*with_fps.time.duration, 2.0);
    }

    using SceneFiles = test::ScratchDirTest;

    TEST_F(SceneFiles, SampleScenesFindTheirBakes)
    {
        for (const auto& [name, path] : sample_scenes()) {
            SCOPED_TRACE(path);
            fs::create_directories(dir() / name);
            const fs::path copy = dir() / name / "scene.json";
            fs::copy_file(path, copy);
            // Empty stand-ins for the bakes the scene names (the parser only checks existence),
            // in its directory or, for the collision scenes, in another sample's.
            const Scene without = read_scene(copy.string(), no_file_check());
            for (const ObjectSettings& object : without.objects) {
                fs::create_directories(fs::path(object.bake).parent_path());
                std::ofstream(object.bake).put('\n');
            }
            const Scene scene = read_scene(copy.string());
            EXPECT_EQ(scene.objects[0].bake, without.objects[0].bake);
            EXPECT_TRUE(fs::exists(scene.objects[0].bake));
            EXPECT_EQ(fs::path(scene.objects[0].bake).parent_path().parent_path(), dir());
        }
    }

    TEST_F(SceneFiles, RelativeScenePathResolvesAgainstTheWorkingDirectory)
    {
        write_text("body.h5", "");
        const fs::path previous = fs::current_path();
        fs::current_path(dir());
        Scene scene;
        EXPECT_NO_THROW(scene = parse_scene(R"({"objects": [{"bake": "body.h5"}]})", "scene.json"));
        fs::current_path(previous);
        EXPECT_EQ(scene.objects[0].bake, (dir() / "body.h5").string());
    }

    TEST(SceneReference, EveryDeclaredKeyIsInItsSectionTable)
    {
        const std::string markdown = scene_reference_markdown();
        const std::vector<SceneKeyInfo> keys = scene_keys();
        ASSERT_GE(keys.size(), 40u);
        std::set<std::string> sections;
        for (const SceneKeyInfo& key : keys) {
            SCOPED_TRACE(key.section + " " + key.key);
            EXPECT_FALSE(key.type.empty());
            EXPECT_FALSE(key.default_value.empty());
            EXPECT_FALSE(key.doc.empty());
            const std::string heading
                = key.section.empty() ? "### Top level\n" : "### `" + key.section + "`\n";
            const std::size_t start = markdown.find(heading);
            ASSERT_NE(start, std::string::npos);
            const std::size_t end = markdown.find("\n### ", start + 1);
            const std::string table = markdown.substr(start, end - start);
            const std::string row = "| `" + key.key + "` | " + key.type + " | " + key.default_value
                + " | " + key.doc + " |\n";
            EXPECT_NE(table.find(row), std::string::npos) << row;
            sections.insert(key.section);
        }
        // One table per section, each heading once.
        std::size_t headings = 0;
        for (std::size_t at = markdown.find("### "); at != std::string::npos;
             at = markdown.find("### ", at + 1))
            ++headings;
        EXPECT_EQ(headings, sections.size());
        for (const char* section : { "", "time", "solver", "objects[]", "objects[].material",
                 "objects[].pins[]", "objects[].pins[].box", "objects[].pins[].sphere",
                 "objects[].pins[].motion[]", "colliders[]", "output" })
            EXPECT_EQ(sections.count(section), 1u) << section;
        // A few rows as a reader sees them.
        EXPECT_NE(markdown.find("| `dt` | number > 0 | 1/60 |"), std::string::npos);
        EXPECT_NE(
            markdown.find("| `poisson_ratio` | number in [0, 0.5) | 0.3 |"), std::string::npos);
        EXPECT_NE(markdown.find("| `bake` | path | required |"), std::string::npos);
        EXPECT_NE(markdown.find("| `gravity` | [x, y, z] | [0, -9.81, 0] |"), std::string::npos);
    }

} // namespace
} // namespace mat
