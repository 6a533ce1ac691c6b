// glTF 2.0 (.gltf with an embedded buffer, .glb) through assimp: node transforms give world space.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "surface_test_meshes.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using SurfaceGltf = test::SurfaceScratchTest;

    // ---- glTF 2.0 -------------------------------------------------------------------------

    std::string base64(const std::vector<char>& bytes)
    {
        static const char* table
            = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        std::string out;
        for (std::size_t i = 0; i < bytes.size(); i += 3) {
            std::uint32_t chunk = 0;
            const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
            for (std::size_t k = 0; k < 3; ++k)
                chunk = (chunk << 8) | (k < n ? static_cast<unsigned char>(bytes[i + k]) : 0u);
            for (std::size_t k = 0; k < 4; ++k)
                out += k <= n ? table[(chunk >> (18 - 6 * k)) & 63u] : '=';
        }
        return out;
    }

    template <typename T> void append(std::vector<char>& bytes, T value)
    {
        const char* p = reinterpret_cast<const char*>(&value);
        bytes.insert(bytes.end(), p, p + sizeof(T));
    }

    /// A regular tetrahedron's buffer: 4 float positions (48 bytes), 12 uint32 indices (48).
    const SurfaceMesh& tetrahedron()
    {
        static const SurfaceMesh mesh = [] {
            SurfaceMesh m;
            m.positions.resize(4, 3);
            m.positions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
            m.faces.resize(4, 3);
            m.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
            return m;
        }();
        return mesh;
    }

    std::vector<char> tetrahedron_buffer()
    {
        std::vector<char> bytes;
        for (Index i = 0; i < 4; ++i)
            for (int d = 0; d < 3; ++d)
                append(bytes, static_cast<float>(tetrahedron().positions(i, d)));
        for (Index f = 0; f < 4; ++f)
            for (int k = 0; k < 3; ++k)
                append(bytes, static_cast<std::uint32_t>(tetrahedron().faces(f, k)));
        return bytes;
    }

    /// A scene instancing the tetrahedron twice: under a translated parent scaled by 2
    /// (x -> 2x + (10, 0, 0)) and mirrored (x -> (-x - 10, y, z)).
    std::string tetrahedron_gltf(const std::string& buffer_uri)
    {
        return R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [
    {"translation": [10, 0, 0], "children": [2]},
    {"mesh": 0, "translation": [-10, 0, 0], "scale": [-1, 1, 1]},
    {"mesh": 0, "scale": [2, 2, 2]}
  ],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
  "buffers": [{"byteLength": 96)"
            + buffer_uri + R"(}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 48, "target": 34962},
    {"buffer": 0, "byteOffset": 48, "byteLength": 48, "target": 34963}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
     "min": [0, 0, 0], "max": [1, 1, 1]},
    {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}
  ]
})";
    }

    void expect_two_tetrahedra_in_world_space(const SurfaceMesh& mesh)
    {
        ASSERT_EQ(mesh.num_vertices(), 8);
        ASSERT_EQ(mesh.num_faces(), 8);
        SurfaceMesh scaled = test::transformed(tetrahedron(), 2.0, Vec3(10, 0, 0));
        SurfaceMesh mirrored = test::transformed(tetrahedron(), 1.0, Vec3(10, 0, 0));
        mirrored.positions.col(0) *= -1.0;
        // Mirroring reverses the winding; the reader must restore it to stay outward.
        test::expect_same_surface(test::concatenate(scaled, test::flipped(mirrored)), mesh, 1e-6);
        const SurfaceReport report = validate_surface(mesh);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary("tetrahedra");
        EXPECT_EQ(report.num_components, 2);
        EXPECT_NEAR(report.signed_volume, (8.0 + 1.0) / 6.0, 1e-6);
    }

    TEST_F(SurfaceGltf, GltfEmbeddedBufferNodeTransformsGiveWorldSpace)
    {
        const std::string uri = R"(, "uri": "data:application/octet-stream;base64,)"
            + base64(tetrahedron_buffer()) + "\"";
        expect_two_tetrahedra_in_world_space(
            read_surface(write_text("tetrahedra.gltf", tetrahedron_gltf(uri))));
    }

    TEST_F(SurfaceGltf, GlbBinaryContainer)
    {
        std::string json = tetrahedron_gltf("");
        json.resize((json.size() + 3) / 4 * 4, ' ');
        const std::vector<char> bin = tetrahedron_buffer(); // 96 bytes, already 4-aligned
        std::vector<char> glb;
        append<std::uint32_t>(glb, 0x46546C67u); // "glTF"
        append<std::uint32_t>(glb, 2u);
        append<std::uint32_t>(
            glb, static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
        append<std::uint32_t>(glb, static_cast<std::uint32_t>(json.size()));
        append<std::uint32_t>(glb, 0x4E4F534Au); // "JSON"
        glb.insert(glb.end(), json.begin(), json.end());
        append<std::uint32_t>(glb, static_cast<std::uint32_t>(bin.size()));
        append<std::uint32_t>(glb, 0x004E4942u); // "BIN\0"
        glb.insert(glb.end(), bin.begin(), bin.end());
        expect_two_tetrahedra_in_world_space(read_surface(write_bytes("tetrahedra.glb", glb)));
    }

} // namespace
} // namespace mat
