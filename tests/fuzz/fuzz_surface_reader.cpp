// libFuzzer target for the surface readers, through read_surface() as mat-bake calls it: the
// first byte picks the file's extension (OFF and OBJ: our text checks, then assimp; PLY: our
// own reader; STL, glTF and GLB: assimp), the rest is the file, written to a scratch path.
// What mat-bake does next, validate_surface(), runs on what was read. Every input must either
// throw mat::Error or give a surface whose faces index its vertices (docs/building.md,
// Fuzzing); anything else is a finding.

#include <cstdint>

#include "common/error.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    mat::fuzz::quiet_logger();
    if (size == 0)
        return 0;
    static const char* const extensions[] = { ".off", ".obj", ".ply", ".stl", ".gltf", ".glb" };
    const char* extension = extensions[data[0] % 6];
    const std::string path = mat::fuzz::write_scratch(
        std::string("surface") + extension, mat::fuzz::as_text(data + 1, size - 1));
    mat::SurfaceMesh mesh;
    try {
        mesh = mat::read_surface(path);
    } catch (const mat::Error&) {
        return 0;
    }
    const auto check = [](bool condition, const char* what) {
        mat::fuzz::check(condition, "fuzz_surface_reader", what);
    };
    check(mesh.num_faces() > 0, "a surface read has faces");
    check(mesh.faces.minCoeff() >= 0 && mesh.faces.maxCoeff() < mesh.num_vertices(),
        "face indices in range");
    const mat::SurfaceReport report = mat::validate_surface(mesh);
    check(report.num_faces == mesh.num_faces() && !report.invalid_indices,
        "validation sees every face");
    (void)report.summary(path);
    return 0;
}
