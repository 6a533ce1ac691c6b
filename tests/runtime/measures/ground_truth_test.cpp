// The exhaustive ground truth against the plain O(F^2) loop over all triangle pairs, on
// perturbed overlapping geodesic spheres (object-object and self intersections), and its input
// checks.

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "runtime/collision/triangle_tests.hpp"
#include "runtime/measures/ground_truth.hpp"
#include "tests/support/error_checks.hpp"

namespace mat {
namespace {

    // A geodesic sphere: each icosahedron face cut into frequency^2 triangles (20 f^2 in all),
    // vertices pushed to the sphere. Vertices shared by faces are computed once from the same
    // integer weights, so the mesh is closed and welded.
    SurfaceMesh geodesic_sphere(int frequency, const Vec3& center, double radius)
    {
        const double g = (1.0 + std::sqrt(5.0)) / 2.0;
        const std::array<Vec3, 12> corners = { Vec3(-1, g, 0), Vec3(1, g, 0), Vec3(-1, -g, 0),
            Vec3(1, -g, 0), Vec3(0, -1, g), Vec3(0, 1, g), Vec3(0, -1, -g), Vec3(0, 1, -g),
            Vec3(g, 0, -1), Vec3(g, 0, 1), Vec3(-g, 0, -1), Vec3(-g, 0, 1) };
        const int faces[20][3] = { { 0, 11, 5 }, { 0, 5, 1 }, { 0, 1, 7 }, { 0, 7, 10 },
            { 0, 10, 11 }, { 1, 5, 9 }, { 5, 11, 4 }, { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 },
            { 3, 9, 4 }, { 3, 4, 2 }, { 3, 2, 6 }, { 3, 6, 8 }, { 3, 8, 9 }, { 4, 9, 5 },
            { 2, 4, 11 }, { 6, 2, 10 }, { 8, 6, 7 }, { 9, 8, 1 } };
        std::map<std::array<int, 6>, int> index;
        std::vector<Vec3> positions;
        std::vector<std::array<int, 3>> triangles;
        for (const auto& face : faces) {
            const auto vertex = [&](int i, int j) {
                // Weights i, j, f - i - j on the face's corners, as sorted (corner, weight).
                std::array<std::pair<int, int>, 3> w = { std::make_pair(face[0], i),
                    std::make_pair(face[1], j), std::make_pair(face[2], frequency - i - j) };
                // Unused corners (weight 0) become -1 before sorting.
                for (auto& [corner, weight] : w)
                    corner = weight == 0 ? -1 : corner;
                std::sort(w.begin(), w.end());
                std::array<int, 6> key {};
                Vec3 p = Vec3::Zero();
                for (int k = 0; k < 3; ++k) {
                    key[2 * k] = w[k].first;
                    key[2 * k + 1] = w[k].second;
                    if (w[k].first >= 0)
                        p += w[k].second * corners[static_cast<std::size_t>(w[k].first)];
                }
                const auto [it, inserted] = index.emplace(key, static_cast<int>(positions.size()));
                if (inserted)
                    positions.push_back(center + radius * p.normalized());
                return it->second;
            };
            for (int i = 0; i < frequency; ++i)
                for (int j = 0; i + j < frequency; ++j) {
                    triangles.push_back({ vertex(i, j), vertex(i + 1, j), vertex(i, j + 1) });
                    if (i + j + 1 < frequency)
                        triangles.push_back(
                            { vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1) });
                }
        }
        SurfaceMesh mesh;
        mesh.positions.resize(static_cast<Index>(positions.size()), 3);
        for (std::size_t v = 0; v < positions.size(); ++v)
            mesh.positions.row(static_cast<Index>(v)) = positions[v].transpose();
        mesh.faces.resize(static_cast<Index>(triangles.size()), 3);
        for (std::size_t f = 0; f < triangles.size(); ++f)
            for (int k = 0; k < 3; ++k)
                mesh.faces(static_cast<Index>(f), k) = triangles[f][static_cast<std::size_t>(k)];
        return mesh;
    }

    // Moves every vertex by a random offset in [-amount, amount]^3, seeded: with offsets of
    // the order of the edge length the surface folds onto itself in places.
    void perturb(SurfaceMesh& mesh, double amount, unsigned seed)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> u(-amount, amount);
        for (Index v = 0; v < mesh.num_vertices(); ++v)
            mesh.positions.row(v) += Eigen::RowVector3d(u(rng), u(rng), u(rng));
    }

    // The plain loop over every pair of triangles.
    std::vector<TrianglePair> brute_force(
        const std::vector<SurfaceMesh>& surfaces, const GroundTruthOptions& options = {})
    {
        std::vector<TrianglePair> out;
        const auto corner = [&](int s, int f, int k) -> Vec3 {
            return surfaces[static_cast<std::size_t>(s)]
                .positions.row(surfaces[static_cast<std::size_t>(s)].faces(f, k))
                .transpose();
        };
        const int n = static_cast<int>(surfaces.size());
        for (int s = 0; s < n; ++s)
            for (int f = 0; f < surfaces[static_cast<std::size_t>(s)].num_faces(); ++f)
                for (int t = s; t < n; ++t)
                    for (int g = (t == s ? f + 1 : 0);
                         g < surfaces[static_cast<std::size_t>(t)].num_faces(); ++g) {
                        if (s == t) {
                            if (!options.self_pairs)
                                continue;
                            bool shared = false;
                            for (int k = 0; k < 3; ++k)
                                for (int l = 0; l < 3; ++l)
                                    shared = shared
                                        || surfaces[static_cast<std::size_t>(s)].faces(f, k)
                                            == surfaces[static_cast<std::size_t>(s)].faces(g, l);
                            if (shared)
                                continue;
                        } else if (!options.object_pairs) {
                            continue;
                        }
                        if (triangles_intersect(corner(s, f, 0), corner(s, f, 1), corner(s, f, 2),
                                corner(t, g, 0), corner(t, g, 1), corner(t, g, 2)))
                            out.push_back({ s, f, t, g });
                    }
        return out;
    }

    TEST(GroundTruth, GeodesicSphereIsClosedAndHasNoSelfIntersection)
    {
        const SurfaceMesh sphere = geodesic_sphere(4, Vec3::Zero(), 1.0);
        EXPECT_EQ(sphere.num_faces(), 20 * 16);
        EXPECT_EQ(sphere.num_vertices(), 10 * 16 + 2); // Euler: V = F / 2 + 2
        EXPECT_TRUE(intersecting_triangle_pairs({ sphere }).empty());
    }

    TEST(GroundTruth, OverlappingPerturbedSpheresMatchTheLoop)
    {
        for (unsigned seed = 1; seed <= 3; ++seed) {
            SurfaceMesh a = geodesic_sphere(5, Vec3::Zero(), 1.0);
            SurfaceMesh b = geodesic_sphere(4, Vec3(1.2, 0.3, -0.2), 0.9);
            perturb(a, 0.15, seed);
            perturb(b, 0.15, seed + 100);
            SurfaceMesh c = geodesic_sphere(3, Vec3(0.2, 1.1, 0.4), 0.5);
            // Triangles much larger than the others (swept against everything): one slicing
            // through all the spheres, and two long slivers.
            SurfaceMesh big;
            big.positions.resize(6, 3);
            big.positions << -2, -2, 0.1, 3, -1.5, -0.1, 0, 3, 0.05, -1.5, 0.2, -1.5, 2.5, 0.3, 1.5,
                2.5, 0.31, 1.52;
            big.faces.resize(2, 3);
            big.faces << 0, 1, 2, 3, 4, 5;
            const std::vector<SurfaceMesh> surfaces = { a, b, c, big };
            const std::vector<TrianglePair> expected = brute_force(surfaces);
            const std::vector<TrianglePair> found = intersecting_triangle_pairs(surfaces);
            EXPECT_EQ(found, expected) << "seed " << seed;

            int self = 0;
            for (const TrianglePair& p : expected)
                self += p[0] == p[2];
            EXPECT_GT(self, 0) << "seed " << seed << ", " << expected.size() << " pairs";
            EXPECT_GT(static_cast<int>(expected.size()) - self, 50) << "seed " << seed;

            GroundTruthOptions only_self;
            only_self.object_pairs = false;
            EXPECT_EQ(
                intersecting_triangle_pairs(surfaces, only_self), brute_force(surfaces, only_self));
            GroundTruthOptions only_object;
            only_object.self_pairs = false;
            EXPECT_EQ(intersecting_triangle_pairs(surfaces, only_object),
                brute_force(surfaces, only_object));
        }
    }

    TEST(GroundTruth, ExactContactsAreFound)
    {
        // Two flat unit squares (2 triangles each) in the plane z = 0 sharing an edge segment
        // but no vertex index (different bodies), and a third square touching the first at one
        // corner from above.
        SurfaceMesh square;
        square.positions.resize(4, 3);
        square.positions << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
        square.faces.resize(2, 3);
        square.faces << 0, 1, 2, 0, 2, 3;
        SurfaceMesh right = square;
        right.positions.col(0).array() += 1.0;
        SurfaceMesh above = square;
        above.positions.col(2).array() += 1.0;
        above.positions.row(0) << 1, 1, 0; // a corner down on the first square's corner
        const std::vector<TrianglePair> found
            = intersecting_triangle_pairs({ square, right, above });
        EXPECT_EQ(found, brute_force({ square, right, above }));
        // The shared edge x = 1 belongs to face 0 of `square` (0,1,2) and faces 0 and 1 of
        // `right` (its vertices 0 and 3 lie on x = 1); the corner (1, 1, 0) is on both faces
        // of `square` and on face 1 of `right` too.
        for (const TrianglePair& p : { TrianglePair { 0, 0, 1, 0 }, TrianglePair { 0, 0, 1, 1 },
                 TrianglePair { 0, 0, 2, 0 }, TrianglePair { 0, 0, 2, 1 },
                 TrianglePair { 0, 1, 2, 0 }, TrianglePair { 0, 1, 2, 1 } })
            EXPECT_NE(std::find(found.begin(), found.end(), p), found.end())
                << p[0] << " " << p[1] << " " << p[2] << " " << p[3];
    }

    TEST(GroundTruth, BadInputNamesTheElement)
    {
        SurfaceMesh mesh = geodesic_sphere(1, Vec3::Zero(), 1.0);
        SurfaceMesh bad_face = mesh;
        bad_face.faces(7, 1) = 99;
        test::expect_error_containing(
            [&] {
                intersecting_triangle_pairs({ mesh, bad_face });
            },
            { "surface 1", "face 7", "99" });
        SurfaceMesh bad_vertex = mesh;
        bad_vertex.positions(3, 2) = std::nan("");
        test::expect_error_containing([&] { intersecting_triangle_pairs({ bad_vertex }); },
            { "surface 0", "vertex 3", "non-finite" });
        EXPECT_TRUE(intersecting_triangle_pairs({}).empty());
    }

} // namespace
} // namespace mat
