// Tests of the medial generator's parts: surface distance (against brute force and the winding
// number), surface sampling, the Delaunay tetrahedralization (empty circumspheres) and the inner
// Voronoi complex.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "common/error.hpp"
#include "formats/surface_io.hpp"
#include "preprocess/medial/cgal_delaunay.hpp"
#include "preprocess/medial/medial_fit.hpp"
#include "preprocess/medial/surface_distance.hpp"
#include "preprocess/medial/surface_sampling.hpp"
#include "preprocess/medial/voronoi_medial.hpp"

namespace mat {
namespace {

    SurfaceMesh sample_surface_file(const std::string& name)
    {
        return read_surface(std::string(MAT_SAMPLES_DIR) + "/" + name + "/" + name + ".obj");
    }

    double segment_distance(const Vec3& p, const Vec3& a, const Vec3& b)
    {
        const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        return (a + t * (b - a) - p).norm();
    }

    // Point-triangle distance the plain way: the foot on the plane if it falls inside, else the
    // nearest edge.
    double triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c)
    {
        const Vec3 n = (b - a).cross(c - a).normalized();
        const Vec3 foot = p - n.dot(p - a) * n;
        const bool inside = (b - a).cross(foot - a).dot(n) >= 0
            && (c - b).cross(foot - b).dot(n) >= 0 && (a - c).cross(foot - c).dot(n) >= 0;
        if (inside)
            return std::abs(n.dot(p - a));
        return std::min(
            { segment_distance(p, a, b), segment_distance(p, b, c), segment_distance(p, c, a) });
    }

    TEST(SurfaceDistance, MatchesBruteForceAndTheWindingNumber)
    {
        const SurfaceMesh surface = sample_surface_file("torus");
        const SurfaceDistance distance(surface);
        const Box3 box = distance.bounds();
        std::mt19937 rng(7);
        std::uniform_real_distribution<double> unit(-0.1, 1.1);
        for (int trial = 0; trial < 300; ++trial) {
            const Vec3 p = box.min()
                + Vec3(unit(rng), unit(rng), unit(rng)).cwiseProduct(box.max() - box.min());
            double brute = std::numeric_limits<double>::infinity();
            for (Index f = 0; f < surface.num_faces(); ++f)
                brute = std::min(brute,
                    triangle_distance(p, surface.positions.row(surface.faces(f, 0)),
                        surface.positions.row(surface.faces(f, 1)),
                        surface.positions.row(surface.faces(f, 2))));
            const SurfaceClosestPoint closest = distance.closest(p);
            EXPECT_NEAR(closest.distance, brute, 1e-12) << "trial " << trial;
            EXPECT_NEAR((closest.point - p).norm(), brute, 1e-12);
            const double sd = distance.signed_distance(p);
            EXPECT_NEAR(std::abs(sd), brute, 1e-12);
            EXPECT_EQ(sd<0, winding_number(surface, p)> 0.5) << "trial " << trial;
            EXPECT_EQ(distance.any_within(p, brute * 1.001), true);
            EXPECT_EQ(distance.any_within(p, brute * 0.999), false);
        }
    }

    TEST(SurfaceSampling, PointsLieOnTheSurfaceSpreadAndRepeat)
    {
        const SurfaceMesh surface = sample_surface_file("rounded_bar");
        const SurfaceDistance distance(surface);
        for (Index target : { Index(500), Index(5000) }) {
            const SurfaceSamples samples = sample_surface(surface, target);
            const Index n = samples.points.rows();
            // The vertices alone exceed 1.3 x 500: thinned to about the target.
            EXPECT_GT(n, target * 6 / 10) << target;
            EXPECT_LT(n, target * 3 / 2) << target;
            std::set<std::array<double, 3>> distinct;
            for (Index i = 0; i < n; ++i) {
                const Vec3 p = samples.points.row(i);
                EXPECT_LT(distance.unsigned_distance(p), 1e-9) << i;
                distinct.insert({ p(0), p(1), p(2) });
                ASSERT_GE(samples.faces(i), 0);
                ASSERT_LT(samples.faces(i), surface.num_faces());
            }
            EXPECT_EQ(Index(distinct.size()), n);
            const SurfaceSamples again = sample_surface(surface, target);
            EXPECT_EQ(again.points, samples.points);
        }
    }

    TEST(Delaunay, EveryCircumsphereIsEmpty)
    {
        std::mt19937 rng(11);
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        MatX3 points(200, 3);
        for (Index i = 0; i < points.rows(); ++i)
            points.row(i) << unit(rng), unit(rng), unit(rng);
        const MatX4i tets = delaunay_tetrahedra(points);
        ASSERT_GT(tets.rows(), 200);
        double volume = 0.0;
        for (Index t = 0; t < tets.rows(); ++t) {
            const Vec3 a = points.row(tets(t, 0)), b = points.row(tets(t, 1)),
                       c = points.row(tets(t, 2)), d = points.row(tets(t, 3));
            EXPECT_TRUE(
                tets(t, 0) < tets(t, 1) && tets(t, 1) < tets(t, 2) && tets(t, 2) < tets(t, 3));
            volume += std::abs((b - a).dot((c - a).cross(d - a))) / 6.0;
            // Circumcenter: equidistant from the four corners.
            Mat3 m;
            m << (b - a).transpose(), (c - a).transpose(), (d - a).transpose();
            const Vec3 rhs(0.5 * (b - a).squaredNorm(), 0.5 * (c - a).squaredNorm(),
                0.5 * (d - a).squaredNorm());
            const Vec3 center = a + m.fullPivLu().solve(rhs);
            const double radius = (center - a).norm();
            for (Index i = 0; i < points.rows(); ++i)
                EXPECT_GE((points.row(i).transpose() - center).norm(), radius * (1 - 1e-9))
                    << "tet " << t << " point " << i;
        }
        EXPECT_LT(volume, 1.0);
        EXPECT_GT(volume, 0.8); // the convex hull of 200 uniform points fills most of the cube
        EXPECT_EQ(delaunay_tetrahedra(points), tets);
    }

    TEST(Delaunay, RejectsFlatInput)
    {
        MatX3 flat(5, 3);
        flat << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.5, 0.3, 0;
        EXPECT_THROW(delaunay_tetrahedra(flat), Error);
        EXPECT_THROW(delaunay_tetrahedra(flat.topRows(3)), Error);
    }

    TEST(VoronoiComplex, SpheresAreInscribedAndIndicesValid)
    {
        const SurfaceMesh surface = sample_surface_file("capsule");
        const SurfaceDistance distance(surface);
        const SurfaceSamples samples = sample_surface(surface, 2000);
        const MatX4i tets = delaunay_tetrahedra(samples.points);
        const double depth = 1e-4 * distance.bounds().diagonal().norm();
        const MedialComplex complex = inner_voronoi_complex(samples.points, tets, distance, depth);
        const Index n = complex.num_spheres();
        ASSERT_GT(n, 100);
        for (Index s = 0; s < n; ++s) {
            const Vec3 c = complex.centers.row(s);
            EXPECT_NEAR(-distance.signed_distance(c), complex.radii(s), 1e-12) << s;
            EXPECT_GT(complex.radii(s), depth) << s;
            // Its contact samples lie on its sphere, up to the gap between the sampled and the
            // true surface.
            for (int k = complex.contact_offsets[static_cast<std::size_t>(s)];
                 k < complex.contact_offsets[static_cast<std::size_t>(s) + 1]; ++k) {
                const Vec3 p = samples.points.row(complex.contact_samples[static_cast<size_t>(k)]);
                EXPECT_GE((p - c).norm(), complex.radii(s) * (1 - 1e-9));
            }
        }
        ASSERT_FALSE(complex.edges.empty());
        ASSERT_FALSE(complex.triangles.empty());
        EXPECT_TRUE(std::is_sorted(complex.edges.begin(), complex.edges.end()));
        EXPECT_TRUE(
            std::adjacent_find(complex.edges.begin(), complex.edges.end()) == complex.edges.end());
        for (const auto& e : complex.edges) {
            EXPECT_LT(e[0], e[1]);
            EXPECT_LT(e[1], n);
            EXPECT_GE(e[0], 0);
        }
        for (const auto& t : complex.triangles) {
            EXPECT_TRUE(t[0] < t[1] && t[1] < t[2] && t[2] < n && t[0] >= 0);
            for (const auto& e :
                { std::array<int, 2> { t[0], t[1] }, { t[1], t[2] }, { t[0], t[2] } })
                EXPECT_TRUE(std::binary_search(complex.edges.begin(), complex.edges.end(), e));
        }
    }

} // namespace
} // namespace mat
