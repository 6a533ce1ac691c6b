#pragma once
// Small meshes built in code for the surface tests, and checks on them.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <vector>

#include "common/mesh_types.hpp"
#include "tests/support/temp_files.hpp"

namespace mat::test {

/// A fresh scratch directory per test under the build tree, removed afterwards.
class SurfaceScratchTest : public ScratchDirTest {
protected:
    SurfaceScratchTest()
        : ScratchDirTest(std::filesystem::path(MAT_BINARY_DIR) / "test_scratch")
    {
    }
};

/// The unit cube [0, 1]^3: 8 vertices, 12 faces, outward.
inline SurfaceMesh unit_cube()
{
    SurfaceMesh mesh;
    mesh.positions.resize(8, 3);
    mesh.positions << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
    mesh.faces.resize(12, 3);
    mesh.faces << 0, 2, 1, 0, 3, 2, // z = 0
        4, 5, 6, 4, 6, 7, // z = 1
        0, 1, 5, 0, 5, 4, // y = 0
        3, 7, 6, 3, 6, 2, // y = 1
        0, 4, 7, 0, 7, 3, // x = 0
        1, 2, 6, 1, 6, 5; // x = 1
    return mesh;
}

/// Concatenates two meshes (b's indices shifted).
inline SurfaceMesh concatenate(const SurfaceMesh& a, const SurfaceMesh& b)
{
    SurfaceMesh out;
    out.positions.resize(a.num_vertices() + b.num_vertices(), 3);
    out.positions << a.positions, b.positions;
    out.faces.resize(a.num_faces() + b.num_faces(), 3);
    out.faces << a.faces, (b.faces.array() + int(a.num_vertices())).matrix();
    return out;
}

/// `mesh` scaled by `scale` then moved by `offset`.
inline SurfaceMesh transformed(SurfaceMesh mesh, double scale, const Vec3& offset)
{
    for (Index i = 0; i < mesh.num_vertices(); ++i)
        mesh.positions.row(i) = scale * mesh.positions.row(i) + offset.transpose();
    return mesh;
}

/// Every face's winding reversed.
inline SurfaceMesh flipped(SurfaceMesh mesh)
{
    mesh.faces.col(1).swap(mesh.faces.col(2));
    return mesh;
}

/// A closed torus (radii R > r) on an n x m grid: n * m vertices, 2 n m faces, outward.
/// With `jitter` > 0 the vertices move randomly (fixed seed) by up to jitter * r, and all
/// coordinates are rounded to float so that they survive single-precision readers exactly.
inline SurfaceMesh torus(int n, int m, double R = 1.0, double r = 0.4, double jitter = 0.0)
{
    std::mt19937 rng(12345);
    std::uniform_real_distribution<double> noise(-jitter * r, jitter * r);
    const double two_pi = 2.0 * 3.14159265358979323846;
    SurfaceMesh mesh;
    mesh.positions.resize(n * m, 3);
    mesh.faces.resize(2 * n * m, 3);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < m; ++j) {
            const double u = two_pi * i / n, v = two_pi * j / m;
            Vec3 p((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                r * std::sin(v));
            if (jitter > 0.0)
                p += Vec3(noise(rng), noise(rng), noise(rng));
            mesh.positions.row(i * m + j) = p.cast<float>().cast<double>().transpose();
        }
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < m; ++j) {
            const int a = i * m + j, b = ((i + 1) % n) * m + j;
            const int c = ((i + 1) % n) * m + (j + 1) % m, d = i * m + (j + 1) % m;
            const int f = 2 * (i * m + j);
            mesh.faces.row(f) << a, b, c;
            mesh.faces.row(f + 1) << a, c, d;
        }
    return mesh;
}

/// The triangles of `mesh` as position triples, each rotated to start at its smallest position
/// (orientation kept), the list sorted: equal for meshes that differ only in vertex numbering.
inline std::vector<std::array<double, 9>> canonical_triangles(const SurfaceMesh& mesh)
{
    std::vector<std::array<double, 9>> out;
    for (Index f = 0; f < mesh.num_faces(); ++f) {
        std::array<std::array<double, 3>, 3> corners;
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d)
                corners[k][d] = mesh.positions(mesh.faces(f, k), d);
        const int first = int(std::min_element(corners.begin(), corners.end()) - corners.begin());
        std::array<double, 9> tri;
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d)
                tri[3 * k + d] = corners[(first + k) % 3][d];
        out.push_back(tri);
    }
    std::sort(out.begin(), out.end());
    return out;
}

/// Same triangles (positions and orientation) up to vertex numbering, within `tolerance`.
inline void expect_same_surface(const SurfaceMesh& a, const SurfaceMesh& b, double tolerance)
{
    ASSERT_EQ(a.num_vertices(), b.num_vertices());
    ASSERT_EQ(a.num_faces(), b.num_faces());
    const auto ta = test::canonical_triangles(a);
    const auto tb = test::canonical_triangles(b);
    for (std::size_t f = 0; f < ta.size(); ++f)
        for (int k = 0; k < 9; ++k)
            ASSERT_NEAR(ta[f][k], tb[f][k], tolerance) << "triangle " << f;
}

/// The unit cube as an ASCII PLY of 6 quads.
inline const char* const k_cube_quads_ply = R"(ply
format ascii 1.0
element vertex 8
property float x
property float y
property float z
element face 6
property list uchar int vertex_indices
end_header
0 0 0
1 0 0
1 1 0
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
4 0 3 2 1
4 4 5 6 7
4 0 1 5 4
4 3 7 6 2
4 0 4 7 3
4 1 2 6 5
)";

} // namespace mat::test
