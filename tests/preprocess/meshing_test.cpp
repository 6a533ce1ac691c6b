// Tests of preprocess/meshing: CGAL Mesh_3 tetrahedralization and implicit surface meshing, the
// Morton renumbering and the tet quality measures.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "common/error.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "preprocess/meshing/cgal_mesh3.hpp"
#include "preprocess/meshing/mesh_measures.hpp"
#include "preprocess/meshing/morton_order.hpp"
#include "preprocess/meshing/tet_quality.hpp"

namespace mat {
namespace {

    /// An icosahedron subdivided `levels` times, vertices on the sphere of radius `radius`,
    /// faces outward.
    SurfaceMesh icosphere(int levels, double radius)
    {
        const double t = (1.0 + std::sqrt(5.0)) / 2.0;
        std::vector<Vec3> points = { { -1, t, 0 }, { 1, t, 0 }, { -1, -t, 0 }, { 1, -t, 0 },
            { 0, -1, t }, { 0, 1, t }, { 0, -1, -t }, { 0, 1, -t }, { t, 0, -1 }, { t, 0, 1 },
            { -t, 0, -1 }, { -t, 0, 1 } };
        std::vector<Eigen::Vector3i> faces = { { 0, 11, 5 }, { 0, 5, 1 }, { 0, 1, 7 }, { 0, 7, 10 },
            { 0, 10, 11 }, { 1, 5, 9 }, { 5, 11, 4 }, { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 },
            { 3, 9, 4 }, { 3, 4, 2 }, { 3, 2, 6 }, { 3, 6, 8 }, { 3, 8, 9 }, { 4, 9, 5 },
            { 2, 4, 11 }, { 6, 2, 10 }, { 8, 6, 7 }, { 9, 8, 1 } };
        for (auto& p : points)
            p.normalize();
        for (int level = 0; level < levels; ++level) {
            std::map<std::pair<int, int>, int> midpoints;
            auto midpoint = [&](int a, int b) {
                const auto key = std::minmax(a, b);
                const auto it = midpoints.find(key);
                if (it != midpoints.end())
                    return it->second;
                points.push_back((points[a] + points[b]).normalized());
                const int index = static_cast<int>(points.size()) - 1;
                midpoints.emplace(key, index);
                return index;
            };
            std::vector<Eigen::Vector3i> refined;
            for (const auto& f : faces) {
                const int ab = midpoint(f(0), f(1)), bc = midpoint(f(1), f(2)),
                          ca = midpoint(f(2), f(0));
                refined.push_back({ f(0), ab, ca });
                refined.push_back({ f(1), bc, ab });
                refined.push_back({ f(2), ca, bc });
                refined.push_back({ ab, bc, ca });
            }
            faces = refined;
        }
        SurfaceMesh mesh;
        mesh.positions.resize(static_cast<Index>(points.size()), 3);
        for (std::size_t i = 0; i < points.size(); ++i)
            mesh.positions.row(static_cast<Index>(i)) = radius * points[i].transpose();
        mesh.faces.resize(static_cast<Index>(faces.size()), 3);
        for (std::size_t i = 0; i < faces.size(); ++i)
            mesh.faces.row(static_cast<Index>(i)) = faces[i].transpose();
        return mesh;
    }

    /// The cube [-1, 1]^3 as 12 outward triangles.
    SurfaceMesh cube()
    {
        SurfaceMesh mesh;
        mesh.positions.resize(8, 3);
        for (int i = 0; i < 8; ++i)
            mesh.positions.row(i) << (i & 1 ? 1 : -1), (i & 2 ? 1 : -1), (i & 4 ? 1 : -1);
        mesh.faces.resize(12, 3);
        mesh.faces << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4,
            2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
        return mesh;
    }

    double diagonal(const MatX3& positions)
    {
        return (positions.colwise().maxCoeff() - positions.colwise().minCoeff()).norm();
    }

    bool point_in_tet(const TetMesh& mesh, Index t, const Vec3& x)
    {
        const Vec3 p0 = mesh.positions.row(mesh.tets(t, 0)).transpose();
        Mat3 edges;
        for (int k = 1; k < 4; ++k)
            edges.col(k - 1) = mesh.positions.row(mesh.tets(t, k)).transpose() - p0;
        const Vec3 b = edges.partialPivLu().solve(x - p0);
        const double tolerance = 1e-9;
        return b.minCoeff() >= -tolerance && b.sum() <= 1.0 + tolerance;
    }

    bool point_in_mesh(const TetMesh& mesh, const Vec3& x)
    {
        for (Index t = 0; t < mesh.num_tets(); ++t)
            if (point_in_tet(mesh, t, x))
                return true;
        return false;
    }

    void expect_valid_tet_mesh(const TetMesh& mesh)
    {
        ASSERT_GT(mesh.num_tets(), 0);
        EXPECT_GT(tet_signed_volumes(mesh).minCoeff(), 0.0);
        EXPECT_GE(mesh.tets.minCoeff(), 0);
        EXPECT_LT(mesh.tets.maxCoeff(), mesh.num_vertices());
        std::vector<bool> used(static_cast<std::size_t>(mesh.num_vertices()), false);
        for (Index i = 0; i < mesh.tets.size(); ++i)
            used[static_cast<std::size_t>(mesh.tets.data()[i])] = true;
        EXPECT_TRUE(std::all_of(used.begin(), used.end(), [](bool u) { return u; }))
            << "every vertex must be used by a tet";
    }

    TEST(Tetrahedralize, IcosphereVolumeOrientationAndCoverage)
    {
        const SurfaceMesh surface = icosphere(3, 1.0);
        const TetMesh mesh = tetrahedralize(surface, tetrahedralize_options_for(2.0, 0.1));
        expect_valid_tet_mesh(mesh);
        const double enclosed = surface_signed_volume(surface);
        const double meshed = tet_signed_volumes(mesh).sum();
        EXPECT_NEAR(meshed / enclosed, 1.0, 0.03);
        // Points just inside the surface are covered by the tets.
        for (Index v = 0; v < surface.num_vertices(); v += 7) {
            const Vec3 x = 0.95 * surface.positions.row(v).transpose();
            EXPECT_TRUE(point_in_mesh(mesh, x)) << "point " << x.transpose();
        }
        EXPECT_TRUE(point_in_mesh(mesh, Vec3::Zero()));
        EXPECT_GT(min_dihedral_angle_degrees(mesh), 1.0);
    }

    TEST(Tetrahedralize, IsDeterministic)
    {
        const SurfaceMesh surface = icosphere(2, 1.0);
        const TetrahedralizeOptions options = tetrahedralize_options_for(2.0, 0.15);
        const TetMesh first = tetrahedralize(surface, options);
        const TetMesh second = tetrahedralize(surface, options);
        ASSERT_EQ(first.num_tets(), second.num_tets());
        ASSERT_EQ(first.num_vertices(), second.num_vertices());
        EXPECT_EQ(first.tets, second.tets);
        EXPECT_EQ(first.positions, second.positions);
    }

    TEST(Tetrahedralize, CubeWithSharpFeaturesKeepsItsVolume)
    {
        TetrahedralizeOptions options = tetrahedralize_options_for(std::sqrt(12.0), 0.15);
        options.detect_features = true;
        const TetMesh mesh = tetrahedralize(cube(), options);
        expect_valid_tet_mesh(mesh);
        // Protected edges and corners: the boundary lies on the cube's faces exactly.
        EXPECT_NEAR(tet_signed_volumes(mesh).sum(), 8.0, 1e-9);
        EXPECT_TRUE(point_in_mesh(mesh, Vec3(0.99, -0.99, 0.99)));
    }

    TEST(Tetrahedralize, VerticesAndTetsAreInMortonOrder)
    {
        const TetMesh mesh
            = tetrahedralize(icosphere(2, 1.0), tetrahedralize_options_for(2.0, 0.1));
        Box3 box(mesh.positions.colwise().minCoeff().transpose(),
            mesh.positions.colwise().maxCoeff().transpose());
        const auto keys = morton_keys(mesh.positions, box);
        EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
    }

    TEST(Tetrahedralize, RejectsBadInput)
    {
        SurfaceMesh open = icosphere(1, 1.0);
        open.faces.conservativeResize(open.num_faces() - 1, 3);
        EXPECT_THROW(tetrahedralize(open, tetrahedralize_options_for(2.0, 0.1)), Error);
        TetrahedralizeOptions zero = tetrahedralize_options_for(2.0, 0.1);
        zero.cell_size = 0.0;
        EXPECT_THROW(tetrahedralize(icosphere(1, 1.0), zero), Error);
        SurfaceMesh out_of_range = icosphere(1, 1.0);
        out_of_range.faces(3, 1) = 1000;
        EXPECT_THROW(tetrahedralize(out_of_range, tetrahedralize_options_for(2.0, 0.1)), Error);
    }

    TEST(Tetrahedralize, Armadillo)
    {
        const std::string path = std::string(MAT_SAMPLES_DIR) + "/meshes/armadillo.off";
        const SurfaceMesh surface = read_surface(path);
        const TetMesh mesh = tetrahedralize(
            surface, tetrahedralize_options_for(diagonal(surface.positions), k_default_tet_size));
        expect_valid_tet_mesh(mesh);
        EXPECT_GT(mesh.num_tets(), 20000);
        EXPECT_LT(mesh.num_tets(), 50000);
        const double enclosed = surface_signed_volume(surface);
        EXPECT_NEAR(tet_signed_volumes(mesh).sum() / enclosed, 1.0, 0.05);
        const TetQuality quality = tet_quality(mesh);
        EXPECT_GT(quality.min_dihedral_degrees, 2.0);
        RecordProperty("num_tets", static_cast<int>(mesh.num_tets()));
    }

    TEST(MeshImplicitSurface, SphereIsClosedOutwardAndOnTheZeroSet)
    {
        const double radius = 0.7;
        const auto sdf = [radius](const Vec3& x) { return x.norm() - radius; };
        ImplicitSurfaceOptions options;
        options.facet_size = 0.1;
        options.facet_distance = 0.005;
        const Box3 bounds(Vec3::Constant(-1.0), Vec3::Constant(1.0));
        const SurfaceMesh surface = mesh_implicit_surface(sdf, bounds, options);
        const SurfaceReport report = validate_surface(surface);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary("sphere");
        EXPECT_EQ(report.num_components, 1);
        EXPECT_GT(surface_signed_volume(surface), 0.0);
        EXPECT_NEAR(surface_signed_volume(surface), 4.0 / 3.0 * M_PI * std::pow(radius, 3),
            0.03 * std::pow(radius, 3) * 4.0);
        double max_error = 0.0;
        for (Index v = 0; v < surface.num_vertices(); ++v)
            max_error = std::max(max_error, std::abs(sdf(surface.positions.row(v).transpose())));
        EXPECT_LT(max_error, 1e-8);

        const SurfaceMesh again = mesh_implicit_surface(sdf, bounds, options);
        EXPECT_EQ(surface.faces, again.faces);
        EXPECT_EQ(surface.positions, again.positions);
    }

    TEST(MeshImplicitSurface, RejectsAnEmptyLevelSet)
    {
        const auto positive = [](const Vec3& x) { return 1.0 + x.squaredNorm(); };
        ImplicitSurfaceOptions options;
        options.facet_size = 0.1;
        options.facet_distance = 0.01;
        EXPECT_THROW(mesh_implicit_surface(
                         positive, Box3(Vec3::Constant(-1.0), Vec3::Constant(1.0)), options),
            Error);
    }

    TEST(TetQuality, RegularTetAndCounts)
    {
        TetMesh mesh;
        mesh.positions.resize(4, 3);
        mesh.positions << 1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1;
        mesh.tets.resize(1, 4);
        mesh.tets << 0, 1, 2, 3;
        if (tet_signed_volumes(mesh)(0) < 0)
            std::swap(mesh.tets(0, 2), mesh.tets(0, 3));
        const TetQuality quality = tet_quality(mesh);
        const double regular = std::acos(1.0 / 3.0) * 180.0 / M_PI;
        EXPECT_NEAR(quality.min_dihedral_degrees, regular, 1e-9);
        EXPECT_NEAR(quality.max_dihedral_degrees, regular, 1e-9);
        EXPECT_NEAR(quality.total_volume, 8.0 / 3.0, 1e-12);
        EXPECT_EQ(quality.num_tets, 1);

        // A right-corner tet: 90 degrees at the 3 edges through the corner, acos(1/sqrt 3) at
        // the 3 others.
        mesh.positions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
        mesh.tets << 0, 1, 2, 3;
        const auto angles = tet_dihedral_angles_degrees(mesh.positions.row(0).transpose(),
            mesh.positions.row(1).transpose(), mesh.positions.row(2).transpose(),
            mesh.positions.row(3).transpose());
        EXPECT_NEAR(angles(0), 90.0, 1e-9);
        EXPECT_NEAR(angles(1), 90.0, 1e-9);
        EXPECT_NEAR(angles(2), 90.0, 1e-9);
        const double other = std::acos(1.0 / std::sqrt(3.0)) * 180.0 / M_PI;
        EXPECT_NEAR(angles(3), other, 1e-9);
        EXPECT_NEAR(angles(4), other, 1e-9);
        EXPECT_NEAR(angles(5), other, 1e-9);
    }

    TEST(MortonOrder, ReorderKeepsTheMesh)
    {
        TetMesh mesh;
        mesh.positions.resize(5, 3);
        mesh.positions << 1, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
        mesh.tets.resize(2, 4);
        mesh.tets << 1, 2, 3, 4, 0, 3, 2, 4;
        const TetMesh reordered = morton_reorder(mesh);
        ASSERT_EQ(reordered.num_tets(), 2);
        std::multiset<std::vector<double>> before, after;
        for (Index t = 0; t < 2; ++t) {
            std::vector<double> a, b;
            for (int k = 0; k < 4; ++k)
                for (int d = 0; d < 3; ++d) {
                    a.push_back(mesh.positions(mesh.tets(t, k), d));
                    b.push_back(reordered.positions(reordered.tets(t, k), d));
                }
            before.insert(a);
            after.insert(b);
        }
        EXPECT_EQ(before, after);
        EXPECT_EQ(reordered.positions.row(0), Eigen::RowVector3d(0, 0, 0));
        EXPECT_NEAR(
            tet_signed_volumes(reordered).minCoeff(), tet_signed_volumes(mesh).minCoeff(), 1e-15);
    }

} // namespace
} // namespace mat
