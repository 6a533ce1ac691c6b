// Tests of preprocess/samples: every sample's medial mesh is valid and its surface is a closed,
// outward mesh of the medial mesh's envelope.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "formats/medial_io.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "preprocess/medial/medial_fit.hpp"
#include "preprocess/samples/sample_generator.hpp"

namespace mat {
namespace {

    /// Coarse surfaces keep the tests fast.
    SampleOptions coarse_options(const std::string& name)
    {
        SampleOptions options;
        options.facet_size = name == "creature" ? 0.03 : 0.06;
        return options;
    }

    double diagonal(const MedialMesh& medial)
    {
        return MedialDistanceField(medial).bounds().diagonal().norm();
    }

    class EverySample : public testing::TestWithParam<std::string> { };

    TEST_P(EverySample, MedialMeshIsValid)
    {
        for (int detail = 1; detail <= 5; ++detail) {
            const MedialMesh medial = make_sample_medial(GetParam(), detail);
            ASSERT_GT(medial.num_spheres(), 0);
            EXPECT_GT(medial.radii.minCoeff(), 0.0);
            std::set<std::vector<int>> primitives;
            for (Index c = 0; c < medial.num_cones(); ++c) {
                std::vector<int> key { medial.cones(c, 0), medial.cones(c, 1) };
                std::sort(key.begin(), key.end());
                EXPECT_NE(key[0], key[1]) << "cone " << c;
                EXPECT_TRUE(primitives.insert(key).second) << "duplicate cone " << c;
                // Neither sphere contains the other: the cone is not degenerate.
                const double gap = (medial.centers.row(key[0]) - medial.centers.row(key[1])).norm();
                EXPECT_GT(gap, std::abs(medial.radii(key[0]) - medial.radii(key[1])) + 1e-3);
            }
            for (Index s = 0; s < medial.num_slabs(); ++s) {
                std::vector<int> key { medial.slabs(s, 0), medial.slabs(s, 1), medial.slabs(s, 2) };
                std::sort(key.begin(), key.end());
                EXPECT_TRUE(std::adjacent_find(key.begin(), key.end()) == key.end())
                    << "slab " << s;
                EXPECT_TRUE(primitives.insert(key).second) << "duplicate slab " << s;
                const Vec3 a = medial.centers.row(key[0]), b = medial.centers.row(key[1]),
                           c = medial.centers.row(key[2]);
                EXPECT_GT((b - a).cross(c - a).norm(), 1e-4) << "degenerate slab " << s;
            }
            // The sizes are about a meter.
            const double size = diagonal(medial);
            EXPECT_GT(size, 0.5);
            EXPECT_LT(size, 2.0);
            if (GetParam() != "creature")
                break; // the others have no detail level
        }
    }

    TEST_P(EverySample, SurfaceIsAClosedOutwardEnvelope)
    {
        const Sample sample = make_sample(GetParam(), coarse_options(GetParam()));
        EXPECT_EQ(sample.name, GetParam());
        const SurfaceReport report = validate_surface(sample.surface);
        EXPECT_TRUE(report.is_closed_manifold()) << report.summary(GetParam());
        EXPECT_EQ(report.num_components, 1);
        EXPECT_GT(report.signed_volume, 0.0);

        const MedialDistanceField field(sample.medial);
        const double size = diagonal(sample.medial);
        double max_error = 0.0;
        for (Index v = 0; v < sample.surface.num_vertices(); ++v)
            max_error = std::max(max_error, std::abs(field(sample.surface.positions.row(v))));
        EXPECT_LT(max_error, 1e-7 * size);

        for (Index s = 0; s < sample.medial.num_spheres(); ++s) {
            const Vec3 center = sample.medial.centers.row(s);
            EXPECT_LT(field(center), 0.0) << "sphere " << s;
            EXPECT_NEAR(winding_number(sample.surface, center), 1.0, 1e-6) << "sphere " << s;
        }
    }

    INSTANTIATE_TEST_SUITE_P(Samples, EverySample, testing::ValuesIn(list_samples()),
        [](const testing::TestParamInfo<std::string>& info) { return info.param; });

    TEST(Samples, ListsTheFourSamples)
    {
        const auto names = list_samples();
        for (const char* name : { "capsule", "rounded_bar", "torus", "creature" })
            EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
    }

    TEST(Samples, GenerationIsDeterministic)
    {
        const Sample first = make_sample("torus", coarse_options("torus"));
        const Sample second = make_sample("torus", coarse_options("torus"));
        EXPECT_EQ(first.surface.positions, second.surface.positions);
        EXPECT_EQ(first.surface.faces, second.surface.faces);
        EXPECT_EQ(first.medial.centers, second.medial.centers);
    }

    TEST(Samples, CreatureLimbsKeepClearOfEachOther)
    {
        // Spheres of one limb stay outside the cones of every other limb and of the far part
        // of their own limb, so the envelope's parts touch only where the medial mesh joins.
        const MedialMesh medial = make_sample_medial("creature", 2);
        for (Index s = 0; s < medial.num_spheres(); ++s) {
            const MedialSphere sphere = MedialSphere::from_mesh(medial, s);
            for (Index c = 0; c < medial.num_cones(); ++c) {
                const int a = medial.cones(c, 0), b = medial.cones(c, 1);
                // Skip cones within 3 spheres along the chain and the cones at the body.
                if (std::abs(a - s) <= 3 || std::abs(b - s) <= 3 || a < 13 || s < 13)
                    continue;
                const double gap = MedialCone::from_mesh(medial, c).signed_distance(sphere.center)
                    - sphere.radius;
                EXPECT_GT(gap, 0.0) << "sphere " << s << " touches cone " << c;
            }
        }
    }

    TEST(Samples, RejectsBadRequests)
    {
        EXPECT_THROW(make_sample("teapot"), Error);
        EXPECT_THROW(make_sample_medial("creature", 6), Error);
        EXPECT_THROW(make_sample_medial("creature", 0), Error);
        SampleOptions options;
        options.facet_size = 0.5;
        EXPECT_THROW(make_sample("capsule", options), Error);
    }

    TEST(Samples, WriteSampleWritesObjAndMa)
    {
        const Sample sample = make_sample("capsule", coarse_options("capsule"));
        const std::filesystem::path directory
            = std::filesystem::path(MAT_BINARY_DIR) / "samples_test_output";
        std::filesystem::remove_all(directory);
        write_sample(sample, directory.string());
        const SurfaceMesh surface = read_surface((directory / "capsule.obj").string());
        EXPECT_EQ(surface.num_faces(), sample.surface.num_faces());
        const MedialMesh medial = read_medial((directory / "capsule.ma").string());
        EXPECT_EQ(medial.centers, sample.medial.centers);
        EXPECT_EQ(medial.radii, sample.medial.radii);
        EXPECT_EQ(medial.cones, sample.medial.cones);
        std::filesystem::remove_all(directory);
    }

} // namespace
} // namespace mat
