// The exact self-intersection test (find_self_intersections, CGAL) against brute force: every
// pair of faces with no common vertex, tested edge against triangle with orientation signs, on
// surfaces in general position (random boxes overlapping, a box whose top is pushed through its
// floor), where no two faces that share a vertex meet elsewhere.

#include <gtest/gtest.h>

#include <array>
#include <random>
#include <utility>
#include <vector>

#include "common/error.hpp"
#include "formats/surface_io.hpp"
#include "preprocess/medial/cgal_delaunay.hpp"

namespace mat {
namespace {

    double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d)
    {
        return (b - a).cross(c - a).dot(d - a);
    }

    // Does the segment pq cross the triangle abc (general position: no zero sign)?
    bool segment_crosses(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c)
    {
        if ((orient(a, b, c, p) > 0) == (orient(a, b, c, q) > 0))
            return false;
        const bool s1 = orient(p, q, a, b) > 0, s2 = orient(p, q, b, c) > 0;
        const bool s3 = orient(p, q, c, a) > 0;
        return s1 == s2 && s2 == s3;
    }

    // Two triangles in general position meet iff an edge of one crosses the other.
    bool triangles_meet(const std::array<Vec3, 3>& t, const std::array<Vec3, 3>& u)
    {
        for (int k = 0; k < 3; ++k) {
            if (segment_crosses(t[k], t[(k + 1) % 3], u[0], u[1], u[2])
                || segment_crosses(u[k], u[(k + 1) % 3], t[0], t[1], t[2]))
                return true;
        }
        return false;
    }

    SelfIntersections brute_force(const SurfaceMesh& s)
    {
        SelfIntersections result;
        const auto corners = [&](Index f) {
            return std::array<Vec3, 3> { s.positions.row(s.faces(f, 0)).transpose(),
                s.positions.row(s.faces(f, 1)).transpose(),
                s.positions.row(s.faces(f, 2)).transpose() };
        };
        for (Index f = 0; f < s.num_faces(); ++f)
            for (Index g = f + 1; g < s.num_faces(); ++g) {
                bool shared = false;
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j)
                        shared = shared || s.faces(f, i) == s.faces(g, j);
                if (shared || !triangles_meet(corners(f), corners(g)))
                    continue;
                if (result.count++ == 0) {
                    result.first_face = f;
                    result.second_face = g;
                }
            }
        return result;
    }

    // A surface built face by face (vectors, then the matrices).
    struct Builder {
        std::vector<Vec3> points;
        std::vector<std::array<int, 3>> faces;

        // Appends a box [0,1]^3 mapped by x -> rotation * (size .* x) + offset, faces outward;
        // returns its first vertex. Its faces 2 and 3 are the top (z = 1).
        int add_box(const Mat3& rotation, const Vec3& size, const Vec3& offset)
        {
            const int base = static_cast<int>(points.size());
            for (int v = 0; v < 8; ++v) {
                const Vec3 unit(v & 1 ? 1.0 : 0.0, v & 2 ? 1.0 : 0.0, v & 4 ? 1.0 : 0.0);
                points.push_back(rotation * size.cwiseProduct(unit) + offset);
            }
            const int box[12][3] = { { 0, 2, 3 }, { 0, 3, 1 }, { 4, 5, 7 }, { 4, 7, 6 },
                { 0, 1, 5 }, { 0, 5, 4 }, { 2, 6, 7 }, { 2, 7, 3 }, { 0, 4, 6 }, { 0, 6, 2 },
                { 1, 3, 7 }, { 1, 7, 5 } };
            for (const auto& f : box)
                faces.push_back({ base + f[0], base + f[1], base + f[2] });
            return base;
        }

        SurfaceMesh mesh() const
        {
            SurfaceMesh s;
            s.positions.resize(static_cast<Index>(points.size()), 3);
            for (std::size_t v = 0; v < points.size(); ++v)
                s.positions.row(static_cast<Index>(v)) = points[v].transpose();
            s.faces.resize(static_cast<Index>(faces.size()), 3);
            for (std::size_t f = 0; f < faces.size(); ++f)
                for (int k = 0; k < 3; ++k)
                    s.faces(static_cast<Index>(f), k) = faces[f][static_cast<std::size_t>(k)];
            return s;
        }
    };

    Mat3 random_rotation(std::mt19937& rng)
    {
        std::normal_distribution<double> normal;
        const Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
        return q.normalized().toRotationMatrix();
    }

    TEST(SelfIntersections, RandomBoxPairsMatchBruteForce)
    {
        std::mt19937 rng(2024);
        std::uniform_real_distribution<double> uniform(0.3, 1.0), shift(-0.8, 0.8);
        Index with_intersections = 0;
        for (int trial = 0; trial < 40; ++trial) {
            Builder builder;
            builder.add_box(
                random_rotation(rng), Vec3(uniform(rng), uniform(rng), uniform(rng)), Vec3::Zero());
            builder.add_box(random_rotation(rng), Vec3(uniform(rng), uniform(rng), uniform(rng)),
                Vec3(shift(rng), shift(rng), shift(rng)));
            const SurfaceMesh s = builder.mesh();
            const SelfIntersections expected = brute_force(s);
            const SelfIntersections found = find_self_intersections(s);
            EXPECT_EQ(found.count, expected.count) << "trial " << trial;
            EXPECT_EQ(found.first_face, expected.first_face) << "trial " << trial;
            EXPECT_EQ(found.second_face, expected.second_face) << "trial " << trial;
            with_intersections += expected.count > 0 ? 1 : 0;
        }
        // Both outcomes occur, so the comparison means something.
        EXPECT_GT(with_intersections, 5);
        EXPECT_LT(with_intersections, 35);
    }

    TEST(SelfIntersections, TopPushedThroughTheFloor)
    {
        // A box whose top becomes a fan around a vertex pushed below the floor: the fan's faces
        // pierce the floor's. One component intersecting itself.
        Builder builder;
        const int base = builder.add_box(Mat3::Identity(), Vec3(2.0, 2.1, 1.0), Vec3::Zero());
        EXPECT_EQ(find_self_intersections(builder.mesh()).count, 0);
        const int middle = static_cast<int>(builder.points.size());
        builder.points.push_back(Vec3(0.93, 1.07, -0.6));
        builder.faces[2] = { base + 4, base + 5, middle };
        builder.faces[3] = { base + 5, base + 7, middle };
        builder.faces.push_back({ base + 7, base + 6, middle });
        builder.faces.push_back({ base + 6, base + 4, middle });
        const SurfaceMesh s = builder.mesh();
        const SelfIntersections expected = brute_force(s);
        const SelfIntersections found = find_self_intersections(s);
        EXPECT_GT(expected.count, 0);
        EXPECT_EQ(found.count, expected.count);
        EXPECT_EQ(found.first_face, expected.first_face);
        EXPECT_EQ(found.second_face, expected.second_face);
    }

    TEST(SelfIntersections, ShippedBoxes)
    {
        const std::string dir = std::string(MAT_TEST_DATA_DIR) + "/bake/";
        const SurfaceMesh overlap = read_surface(dir + "two_boxes_overlap.off");
        const SelfIntersections found = find_self_intersections(overlap);
        const SelfIntersections expected = brute_force(overlap);
        EXPECT_EQ(found.count, expected.count);
        EXPECT_EQ(found.count, 14);
        EXPECT_EQ(std::make_pair(found.first_face, found.second_face),
            std::make_pair(Index(6), Index(12)));
        EXPECT_FALSE(find_self_intersections(read_surface(dir + "two_boxes_apart.off")));
    }

    TEST(SelfIntersections, NonManifoldFacesThrow)
    {
        SurfaceMesh s;
        s.positions = MatX3::Random(5, 3);
        s.faces.resize(3, 3);
        s.faces << 0, 1, 2, 0, 1, 3, 0, 1, 4; // three faces on edge (0, 1), the same way
        EXPECT_THROW(find_self_intersections(s), Error);
    }

} // namespace
} // namespace mat
