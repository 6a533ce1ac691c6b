// Surface reading failures: one clear mat::Error naming the file, and never a crash on garbage.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "surface_test_meshes.hpp"
#include "tests/support/temp_files.hpp"

// assimp 5.2's STL loader leaks its half-built mesh when an ASCII file ends early (the garbage
// test feeds it such files): keep LeakSanitizer to leaks of our own code.
extern "C" const char* __lsan_default_suppressions()
{
    return "leak:libassimp.so\n";
}

namespace mat {
namespace {

    using SurfaceIoErrors = test::SurfaceScratchTest;

    // ---- Failures -------------------------------------------------------------------------

    std::string error_of(const std::string& file)
    {
        try {
            read_surface(file);
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    }

    TEST_F(SurfaceIoErrors, MissingUnreadableAndEmptyFilesNameTheFileAndReason)
    {
        const std::string missing = error_of(path("nothere.obj"));
        EXPECT_NE(missing.find("nothere.obj"), std::string::npos) << missing;
        EXPECT_NE(missing.find("no such file"), std::string::npos) << missing;

        const std::string unknown = error_of(write_text("mesh.unknownformat", "hello\n"));
        EXPECT_NE(unknown.find("mesh.unknownformat: cannot read surface: "), std::string::npos)
            << unknown;
        EXPECT_GT(unknown.size(),
            std::string("mesh.unknownformat: cannot read surface: ").size() + path("").size());

        const std::string no_faces = error_of(write_text("points.obj", "v 0 0 0\nv 1 0 0\n"));
        EXPECT_NE(no_faces.find("points.obj: cannot read surface"), std::string::npos) << no_faces;

        const std::string lines = error_of(write_text("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n"));
        EXPECT_NE(lines.find("no triangle"), std::string::npos) << lines;

        const std::string directory = error_of(dir().string());
        EXPECT_NE(directory.find("directory"), std::string::npos) << directory;
        for (const std::string& message : { missing, unknown, no_faces, lines, directory })
            EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }

    /// Random bytes and truncations of valid files: a mesh with valid indices, or mat::Error.
    TEST_F(SurfaceIoErrors, GarbageNeverCrashes)
    {
        const auto level = logger().level();
        logger().set_level(spdlog::level::off);
        const SurfaceMesh mesh = test::torus(6, 5, 1.0, 0.4, 0.1);
        std::vector<std::pair<std::string, std::vector<char>>> valid;
        for (const char* ext : { ".obj", ".off", ".ply", ".stl" }) {
            write_surface(path(std::string("valid") + ext), mesh);
            const std::string bytes = test::read_file_contents(path(std::string("valid") + ext));
            valid.emplace_back(ext, std::vector<char>(bytes.begin(), bytes.end()));
        }
        valid.emplace_back(".ply",
            std::vector<char>(test::k_cube_quads_ply,
                test::k_cube_quads_ply + std::strlen(test::k_cube_quads_ply)));
        const std::string stl_ascii = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                                      "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
        valid.emplace_back(".stl", std::vector<char>(stl_ascii.begin(), stl_ascii.end()));

        std::mt19937 rng(2024);
        int cases = 0, meshes = 0;
        const auto feed = [&](const std::string& ext, const std::vector<char>& bytes) {
            const std::string file = write_bytes("garbage" + ext, bytes);
            ++cases;
            try {
                const SurfaceMesh got = read_surface(file);
                ++meshes;
                ASSERT_GT(got.num_faces(), 0);
                ASSERT_TRUE(got.faces.minCoeff() >= 0 && got.faces.maxCoeff() < got.num_vertices())
                    << ext << " " << bytes.size() << " bytes";
                validate_surface(got);
            } catch (const Error&) {
            }
        };
        // Truncations at random lengths, some with random bytes flipped.
        for (const auto& [ext, bytes] : valid)
            for (int i = 0; i < 30; ++i) {
                std::vector<char> cut(bytes.begin(),
                    bytes.begin()
                        + std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng));
                if (i % 3 == 0 && !cut.empty())
                    for (int k = 0; k < 4; ++k)
                        cut[std::uniform_int_distribution<std::size_t>(0, cut.size() - 1)(rng)]
                            = static_cast<char>(rng());
                feed(ext, cut);
            }
        // Random bytes, with and without a plausible header.
        const std::vector<std::pair<std::string, std::string>> headers { { ".obj", "" },
            { ".off", "OFF\n" }, { ".ply", "ply\nformat binary_little_endian 1.0\n" },
            { ".stl", "" }, { ".stl", "solid x\n" }, { ".gltf", "{" }, { ".glb", "glTF" },
            { ".bin", "" } };
        for (const auto& [ext, header] : headers)
            for (int i = 0; i < 20; ++i) {
                std::vector<char> bytes(header.begin(), header.end());
                const int n = std::uniform_int_distribution<int>(0, 600)(rng);
                for (int k = 0; k < n; ++k)
                    bytes.push_back(static_cast<char>(rng()));
                feed(ext, bytes);
            }
        logger().set_level(level);
        EXPECT_GE(cases, 300);
        EXPECT_GT(meshes, 0) << "long truncations of text files still hold triangles";
    }

} // namespace
} // namespace mat
