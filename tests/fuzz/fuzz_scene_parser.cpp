// libFuzzer target for the scene file: parse_scene(), the JSON parsing and every check that
// read_scene() makes, without opening the bakes (their paths are resolved, not read). Every
// input must either throw mat::Error or give a scene whose derived settings hold
// (docs/building.md, Fuzzing); anything else is a finding.

#include <cmath>
#include <cstdint>
#include <string>

#include "common/error.hpp"
#include "runtime/scene/scene.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    const std::string text(mat::fuzz::as_text(data, size));
    mat::SceneOptions options;
    options.check_files = false;
    mat::Scene scene;
    try {
        scene = mat::parse_scene(text, "/fuzz/scene.json", options);
    } catch (const mat::Error&) {
        return 0;
    }
    const auto check = [](bool condition, const char* what) {
        mat::fuzz::check(condition, "fuzz_scene_parser", what);
    };
    check(!scene.objects.empty(), "at least one object");
    check(std::isfinite(scene.time.dt) && scene.time.dt > 0.0, "dt finite and > 0");
    check(scene.steps_per_frame >= 1 && scene.frames >= 1, "derived frame settings >= 1");
    check(std::isfinite(scene.frame_interval()), "finite frame interval");
    for (const mat::ObjectSettings& object : scene.objects) {
        check(!object.name.empty(), "objects are named");
        check(!object.bake.empty() && object.bake.front() == '/', "bake paths are absolute");
        check(object.position.allFinite() && object.velocity.allFinite(), "finite placement");
        check(object.material.poisson_ratio >= 0.0 && object.material.poisson_ratio < 0.5,
            "Poisson ratio in [0, 0.5)");
    }
    for (const mat::ColliderSettings& collider : scene.colliders)
        check(collider.normal.allFinite() && std::abs(collider.normal.norm() - 1.0) < 1e-9,
            "unit collider normals");
    return 0;
}
