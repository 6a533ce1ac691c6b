// Tests of the medial generator (preprocess/medial/medial_generator.hpp). On the committed
// samples, whose surfaces are the boundaries of their exact medial meshes' envelopes, the
// generated envelope is compared with the exact one; the result must be a valid bake input
// (cones and slabs, no sliver, centers inside, radii > 0), the same bytes run to run, and bad
// input must give a mat::Error.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <ostream>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "formats/medial_io.hpp"
#include "formats/surface_io.hpp"
#include "preprocess/medial/medial_fit.hpp"
#include "preprocess/medial/medial_generator.hpp"
#include "tests/support/error_checks.hpp"

namespace mat {
namespace {

    SurfaceMesh read_sample_surface(const std::string& name)
    {
        return read_surface(std::string(MAT_SAMPLES_DIR) + "/" + name + "/" + name + ".obj");
    }

    /// Fewer samples than the default keep the tests fast; the fit is still well inside the
    /// thresholds below.
    MedialGeneratorOptions test_options(Index spheres)
    {
        MedialGeneratorOptions options;
        options.spheres = spheres;
        options.samples = 4000;
        options.quality_samples = 6000;
        options.quality_directions = 24;
        return options;
    }

    /// Points on the boundary of an envelope: rays from every sphere center, marched by the
    /// envelope's depth and bisected to the boundary.
    std::vector<Vec3> envelope_boundary_points(const MedialMesh& medial, int directions)
    {
        const MedialDistanceField field(medial);
        const double size = field.bounds().diagonal().norm();
        std::vector<Vec3> points;
        for (Index s = 0; s < medial.num_spheres(); ++s) {
            const Vec3 c = medial.centers.row(s);
            for (int k = 0; k < directions; ++k) {
                const double z = 1.0 - (2.0 * k + 1.0) / directions;
                const double phi = k * M_PI * (3.0 - std::sqrt(5.0));
                const Vec3 u(
                    std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
                double inside = medial.radii(s), outside = inside;
                while (field(c + outside * u) <= 0) {
                    inside = outside;
                    outside += std::max(-field(c + outside * u), 1e-3 * size);
                }
                while (outside - inside > 1e-7 * size) {
                    const double middle = 0.5 * (inside + outside);
                    (field(c + middle * u) > 0 ? outside : inside) = middle;
                }
                points.push_back(c + inside * u);
            }
        }
        return points;
    }

    /// Two-sided Hausdorff distance between two envelopes, from the vertices of the exact one's
    /// boundary mesh and from rays on the generated one.
    double envelope_hausdorff(
        const MedialMesh& generated, const MedialMesh& exact, const SurfaceMesh& exact_boundary)
    {
        const MedialDistanceField generated_field(generated);
        const MedialDistanceField exact_field(exact);
        double worst = 0.0;
        for (Index v = 0; v < exact_boundary.num_vertices(); ++v)
            worst = std::max(
                worst, std::abs(generated_field(exact_boundary.positions.row(v).transpose())));
        for (const Vec3& p : envelope_boundary_points(generated, 32))
            worst = std::max(worst, std::abs(exact_field(p)));
        return worst;
    }

    double min_angle_degrees(const Vec3& a, const Vec3& b, const Vec3& c)
    {
        auto angle = [](const Vec3& u, const Vec3& v) {
            return std::acos(std::clamp(u.normalized().dot(v.normalized()), -1.0, 1.0)) * 180.0
                / M_PI;
        };
        return std::min({ angle(b - a, c - a), angle(a - b, c - b), angle(a - c, b - c) });
    }

    /// Everything the bake needs of a medial mesh, checked on `medial` for `surface`.
    void expect_valid_bake_input(const MedialMesh& medial, const SurfaceMesh& surface)
    {
        const Index n = medial.num_spheres();
        ASSERT_GT(n, 0);
        for (Index s = 0; s < n; ++s) {
            EXPECT_TRUE(medial.centers.row(s).allFinite()) << s;
            EXPECT_TRUE(std::isfinite(medial.radii(s)) && medial.radii(s) > 0) << s;
            EXPECT_GT(winding_number(surface, medial.centers.row(s).transpose()), 0.5)
                << "sphere " << s << " outside";
        }
        for (Index c = 0; c < medial.num_cones(); ++c) {
            const int i = medial.cones(c, 0), j = medial.cones(c, 1);
            ASSERT_TRUE(i >= 0 && j >= 0 && i < n && j < n && i != j) << "cone " << c;
            const double gap = (medial.centers.row(i) - medial.centers.row(j)).norm();
            EXPECT_GT(gap, std::abs(medial.radii(i) - medial.radii(j))) << "degenerate cone " << c;
        }
        for (Index l = 0; l < medial.num_slabs(); ++l) {
            const int i = medial.slabs(l, 0), j = medial.slabs(l, 1), k = medial.slabs(l, 2);
            ASSERT_TRUE(i >= 0 && j >= 0 && k >= 0 && i < n && j < n && k < n) << "slab " << l;
            EXPECT_GE(min_angle_degrees(
                          medial.centers.row(i), medial.centers.row(j), medial.centers.row(k)),
                2.0)
                << "sliver slab " << l;
        }
        // The writer's own checks (no repeated index, no duplicate) pass, and it reads back.
        const MedialMesh again = read_medial_from_string(format_medial(medial), "generated");
        EXPECT_EQ(again.num_spheres(), n);
        EXPECT_EQ(again.cones, medial.cones);
        EXPECT_EQ(again.slabs, medial.slabs);
    }

    struct SampleCase {
        std::string name;
        Index spheres;
        double max_percent; ///< allowed envelope Hausdorff distance, % of the bbox diagonal
    };

    void PrintTo(const SampleCase& sample, std::ostream* out)
    {
        *out << sample.name;
    }

    class GeneratedSample : public testing::TestWithParam<SampleCase> { };

    // Thresholds: about 1.5 x what this configuration measures (capsule 0.65%, rounded_bar
    // 0.68%, torus 0.50%, creature 0.64%), the margin covering last-bit differences between
    // builds (sanitizers, -march), which can change the order of equal-cost collapses.
    TEST_P(GeneratedSample, FitsTheExactEnvelope)
    {
        const SampleCase& sample = GetParam();
        const SurfaceMesh surface = read_sample_surface(sample.name);
        const MedialMesh exact = read_medial(
            std::string(MAT_SAMPLES_DIR) + "/" + sample.name + "/" + sample.name + ".ma");
        MedialQuality quality;
        const MedialMesh medial
            = generate_medial_mesh(surface, test_options(sample.spheres), &quality);
        EXPECT_EQ(medial.num_spheres(), sample.spheres);
        expect_valid_bake_input(medial, surface);

        const double diagonal = quality.bbox_diagonal;
        const double percent = 100.0 * envelope_hausdorff(medial, exact, surface) / diagonal;
        std::printf("%s: %lld spheres, envelope Hausdorff %.3f%% (generator reports %.3f%%)\n",
            sample.name.c_str(), static_cast<long long>(sample.spheres), percent,
            quality.hausdorff_percent());
        EXPECT_LT(percent, sample.max_percent);
        // The generator's own measure agrees with this independent one to a fraction of it.
        EXPECT_NEAR(quality.hausdorff_percent(), percent, 0.25 * percent + 0.05);
        EXPECT_GE(quality.coverage, 0.0);
        EXPECT_LE(quality.coverage, 1.0);
        EXPECT_EQ(quality.spheres, medial.num_spheres());
    }

    INSTANTIATE_TEST_SUITE_P(Samples, GeneratedSample,
        testing::Values(SampleCase { "capsule", 8, 1.0 }, SampleCase { "rounded_bar", 20, 1.0 },
            SampleCase { "torus", 30, 0.75 }, SampleCase { "creature", 80, 1.0 }),
        [](const testing::TestParamInfo<SampleCase>& info) { return info.param.name; });

    TEST(MedialGenerator, IsDeterministic)
    {
        const SurfaceMesh surface = read_sample_surface("torus");
        MedialGeneratorOptions options = test_options(24);
        options.samples = 2000;
        const std::string first = format_medial(generate_medial_mesh(surface, options, nullptr));
        const std::string second = format_medial(generate_medial_mesh(surface, options, nullptr));
        EXPECT_EQ(first, second);
    }

    /// An axis-aligned box as 12 outward triangles.
    SurfaceMesh box(const Vec3& low, const Vec3& high)
    {
        SurfaceMesh mesh;
        mesh.positions.resize(8, 3);
        for (int i = 0; i < 8; ++i)
            mesh.positions.row(i) << (i & 4 ? high(0) : low(0)), (i & 2 ? high(1) : low(1)),
                (i & 1 ? high(2) : low(2));
        mesh.faces.resize(12, 3);
        mesh.faces << 0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2,
            6, 0, 6, 4, 1, 5, 7, 1, 7, 3;
        return mesh;
    }

    SurfaceMesh join(const SurfaceMesh& a, const SurfaceMesh& b)
    {
        SurfaceMesh out;
        out.positions.resize(a.num_vertices() + b.num_vertices(), 3);
        out.positions << a.positions, b.positions;
        out.faces.resize(a.num_faces() + b.num_faces(), 3);
        out.faces << a.faces, (b.faces.array() + static_cast<int>(a.num_vertices())).matrix();
        return out;
    }

    TEST(MedialGenerator, HandlesSharpEdgesAndThinPlates)
    {
        // A box (sharp CAD edges), and a plate 1/50 as thick as it is wide: thinner than the
        // spacing of 2000 samples, which leaves the Voronoi complex in pieces, so the generator
        // samples it again 4x more densely. 30 spheres cannot reach into the corners: they
        // measure 6.7% and 6.2%.
        struct Case {
            SurfaceMesh surface;
            Index samples;
            bool resampled;
        };
        for (const Case& test : { Case { box(Vec3(0, 0, 0), Vec3(1, 0.6, 0.3)), 3000, false },
                 Case { box(Vec3(0, 0, 0), Vec3(1, 1, 0.02)), 2000, true } }) {
            MedialGeneratorOptions options = test_options(30);
            options.samples = test.samples;
            MedialQuality quality;
            const MedialMesh medial = generate_medial_mesh(test.surface, options, &quality);
            expect_valid_bake_input(medial, test.surface);
            EXPECT_EQ(medial.num_spheres(), 30);
            EXPECT_EQ(quality.samples > 2 * test.samples, test.resampled) << quality.samples;
            EXPECT_LT(quality.hausdorff_percent(), 8.5) << quality.summary();
        }
    }

    TEST(MedialGenerator, RejectsWhatItCannotDo)
    {
        const std::string data = MAT_TEST_DATA_DIR;
        MedialGeneratorOptions options = test_options(10);
        options.surface_name = "cube_open.obj";
        test::expect_error_containing(
            [&] {
                generate_medial_mesh(read_surface(data + "/bake/cube_open.obj"), options, nullptr);
            },
            { "cube_open.obj", "not closed" });

        // Two separate boxes cannot share one sphere: the two pieces of the inner Voronoi
        // complex are more than the one sphere asked, refused before any collapse.
        options = test_options(1);
        options.surface_name = "two_boxes";
        const SurfaceMesh two
            = join(box(Vec3(0, 0, 0), Vec3(1, 1, 1)), box(Vec3(2, 0, 0), Vec3(3, 1, 1)));
        test::expect_error_containing([&] { generate_medial_mesh(two, options, nullptr); },
            { "two_boxes", "medial generator: 2 pieces after 0 resamplings",
                "past the bound of the 1 spheres asked", "ask for at least 2 spheres" });
        // With one sphere each it works.
        options.spheres = 2;
        const MedialMesh medial = generate_medial_mesh(two, options, nullptr);
        EXPECT_EQ(medial.num_spheres(), 2);
        expect_valid_bake_input(medial, two);

        options = test_options(0);
        test::expect_error_containing(
            [&] { generate_medial_mesh(box(Vec3(0, 0, 0), Vec3(1, 1, 1)), options, nullptr); },
            { "--spheres must be >= 1" });
        options = test_options(5000);
        test::expect_error_containing(
            [&] { generate_medial_mesh(box(Vec3(0, 0, 0), Vec3(1, 1, 1)), options, nullptr); },
            { "--spheres", "--samples" });
    }

    // The benchmark, outside the default run (it takes a few seconds per mesh):
    //   test_preprocess_medial_generator --gtest_also_run_disabled_tests
    //       --gtest_filter='*CgalDemoMeshes*'
    // reads armadillo.off and bunny00.off from samples/meshes (extracted from libcgal-demo by
    // the install script) and prints the two-sided Hausdorff distance, coverage and time at
    // N = 200 with the default options. Target: at most 2%.
    TEST(MedialGenerator, DISABLED_CgalDemoMeshes)
    {
        for (const char* name : { "armadillo", "bunny00" }) {
            const std::string path = std::string(MAT_SAMPLES_DIR) + "/meshes/" + name + ".off";
            if (!std::filesystem::exists(path)) {
                std::printf("%s: not found, skipped\n", path.c_str());
                continue;
            }
            MedialGeneratorOptions options;
            options.surface_name = path;
            MedialQuality quality;
            const SurfaceMesh surface = read_surface(path);
            const MedialMesh medial = generate_medial_mesh(surface, options, &quality);
            std::printf("%s (%lld triangles): %s\n", name,
                static_cast<long long>(surface.num_faces()), quality.summary().c_str());
            expect_valid_bake_input(medial, surface);
            EXPECT_LE(quality.hausdorff_percent(), 2.0) << name;
        }
    }

} // namespace
} // namespace mat
