// The committed samples are what the generator makes. Floating-point results differ in the last
// bits between build configurations (sanitizers, -march), and CGAL's meshing may then pick other
// vertices, so the comparison is geometric: the same medial mesh to rounding, and a surface on
// the same envelope with the same volume and about the same size.

#include <gtest/gtest.h>

#include "common/medial_primitives.hpp"
#include "formats/medial_io.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"
#include "preprocess/samples/sample_generator.hpp"

namespace mat {
namespace {

    class CommittedSample : public testing::TestWithParam<std::string> { };

    TEST_P(CommittedSample, MatchesTheGenerator)
    {
        const std::string name = GetParam();
        const std::string base = std::string(MAT_SAMPLES_DIR) + "/" + name + "/" + name;
        const MedialMesh committed_medial = read_medial(base + ".ma");
        const SurfaceMesh committed_surface = read_surface(base + ".obj");
        const Sample generated = make_sample(name);

        // Medial mesh: same primitives, same spheres to rounding.
        ASSERT_EQ(committed_medial.num_spheres(), generated.medial.num_spheres());
        EXPECT_EQ(committed_medial.cones, generated.medial.cones);
        EXPECT_EQ(committed_medial.slabs, generated.medial.slabs);
        EXPECT_LT(
            (committed_medial.centers - generated.medial.centers).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_LT((committed_medial.radii - generated.medial.radii).cwiseAbs().maxCoeff(), 1e-12);

        // Surface: closed and outward, on the envelope (OBJ is read at float precision), with the
        // generator's volume and about its vertex count.
        const SurfaceReport committed = validate_surface(committed_surface);
        const SurfaceReport fresh = validate_surface(generated.surface);
        EXPECT_TRUE(committed.is_closed_manifold()) << committed.summary(base + ".obj");
        EXPECT_NEAR(committed.signed_volume, fresh.signed_volume, 2e-3 * fresh.signed_volume);
        EXPECT_NEAR(double(committed_surface.num_vertices()),
            double(generated.surface.num_vertices()), 0.02 * generated.surface.num_vertices());
        const MedialDistanceField field(generated.medial);
        const double diagonal = fresh.bbox.diagonal().norm();
        double worst = 0.0;
        for (Index v = 0; v < committed_surface.num_vertices(); ++v)
            worst
                = std::max(worst, std::abs(field(committed_surface.positions.row(v).transpose())));
        EXPECT_LT(worst, 1e-6 * diagonal) << name;
    }

    INSTANTIATE_TEST_SUITE_P(Samples, CommittedSample,
        testing::Values("capsule", "rounded_bar", "torus", "creature"),
        [](const testing::TestParamInfo<std::string>& info) { return info.param; });

} // namespace
} // namespace mat
