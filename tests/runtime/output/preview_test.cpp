#include "runtime/output/preview.hpp"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "common/error.hpp"

namespace mat {
namespace {

    /// A camera at the origin looking along +z (right = +x, up = +y), 100 px focal length.
    PreviewCamera axis_camera(int width, int height)
    {
        PreviewCamera camera;
        camera.focal = 100.0;
        camera.width = width;
        camera.height = height;
        return camera;
    }

    MatX3 triangle(const Vec3& a, const Vec3& b, const Vec3& c)
    {
        MatX3 positions(3, 3);
        positions << a.transpose(), b.transpose(), c.transpose();
        return positions;
    }

    const MatX3i one_face = (MatX3i(1, 3) << 0, 1, 2).finished();
    const Vec3 white(1, 1, 1), black(0, 0, 0), red(1, 0, 0), blue(0, 0, 1);

    TEST(PreviewCamera, ProjectsThroughTheImageCentre)
    {
        const PreviewCamera camera = axis_camera(200, 100);
        const Vec3 p = camera.project(Vec3(0.5, 0.25, 2.0));
        EXPECT_DOUBLE_EQ(p.x(), 100.0 + 100.0 * 0.25);
        EXPECT_DOUBLE_EQ(p.y(), 50.0 - 100.0 * 0.125); // y grows downwards
        EXPECT_DOUBLE_EQ(p.z(), 2.0);
    }

    TEST(PreviewImage, TriangleCoversExactlyThePixelCentresInside)
    {
        // Screen corners (100, 100), (150, 100), (100, 50): a right triangle of legs 50 whose
        // inside is x >= 100, y <= 100 and x - y <= 50 (pixel centres at +0.5).
        PreviewImage image(200, 200);
        image.clear(white);
        image.draw_mesh(axis_camera(200, 200),
            triangle(Vec3(0, 0, 1), Vec3(0.5, 0, 1), Vec3(0, 0.5, 1)), one_face, red);
        int covered = 0;
        for (int y = 0; y < 200; ++y) {
            for (int x = 0; x < 200; ++x) {
                const double px = x + 0.5, py = y + 0.5;
                const bool inside = px >= 100.0 && py <= 100.0 && px - py <= 50.0;
                ASSERT_EQ(image.covered(x, y), inside) << "pixel " << x << ", " << y;
                covered += inside;
                if (!inside)
                    ASSERT_EQ(image.pixel(x, y), Eigen::Vector3i(255, 255, 255));
                else
                    ASSERT_TRUE(image.pixel(x, y)(0) > 0 && image.pixel(x, y)(1) == 0
                        && image.pixel(x, y)(2) == 0);
            }
        }
        EXPECT_NEAR(covered, 50 * 50 / 2, 50 + 1); // the area, give or take the diagonal
    }

    TEST(PreviewImage, WindingDoesNotMatterAndBehindTheCameraIsSkipped)
    {
        PreviewImage image(200, 200);
        image.clear(white);
        image.draw_mesh(axis_camera(200, 200),
            triangle(Vec3(0, 0, 1), Vec3(0, 0.5, 1), Vec3(0.5, 0, 1)), one_face, red);
        EXPECT_TRUE(image.covered(110, 95));
        PreviewImage behind(200, 200);
        behind.clear(white);
        behind.draw_mesh(axis_camera(200, 200),
            triangle(Vec3(0, 0, -1), Vec3(0.5, 0, -1), Vec3(0, 0.5, -1)), one_face, red);
        for (int y = 0; y < 200; ++y)
            for (int x = 0; x < 200; ++x)
                ASSERT_FALSE(behind.covered(x, y));
    }

    TEST(PreviewImage, HugeAndNonFiniteTrianglesAreSafe)
    {
        // A triangle far larger than the image covers all of it; a NaN vertex draws nothing.
        PreviewImage image(64, 48);
        image.clear(white);
        const PreviewCamera camera = axis_camera(64, 48);
        image.draw_mesh(camera,
            triangle(Vec3(-1e30, -1e30, 1), Vec3(1e30, -1e30, 1), Vec3(0, 1e30, 1)), one_face, red);
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                ASSERT_TRUE(image.covered(x, y)) << x << ", " << y;
        PreviewImage nan_image(64, 48);
        nan_image.clear(white);
        const double nan = std::numeric_limits<double>::quiet_NaN();
        nan_image.draw_mesh(
            camera, triangle(Vec3(nan, 0, 1), Vec3(1, 0, 1), Vec3(0, 1, 1)), one_face, red);
        nan_image.draw_mesh(camera,
            triangle(
                Vec3(0, 0, 1), Vec3(std::numeric_limits<double>::infinity(), 0, 1), Vec3(0, 1, 1)),
            one_face, red);
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                ASSERT_FALSE(nan_image.covered(x, y)) << x << ", " << y;
        // A face naming a vertex that does not exist is an error, not a crash.
        EXPECT_THROW(
            nan_image.draw_mesh(camera, triangle(Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(0, 1, 1)),
                (MatX3i(1, 3) << 0, 1, 3).finished(), red),
            Error);
    }

    TEST(PreviewImage, DepthTestKeepsTheNearerTriangleInEitherOrder)
    {
        // Two large triangles over the image centre: blue at depth 1, red at depth 2.
        const MatX3 near_one = triangle(Vec3(-1, -1, 1), Vec3(1, -1, 1), Vec3(0, 1, 1));
        const MatX3 far_one = triangle(Vec3(-2, -2, 2), Vec3(2, -2, 2), Vec3(0, 2, 2));
        for (const bool near_first : { true, false }) {
            PreviewImage image(100, 100);
            image.clear(white);
            const PreviewCamera camera = axis_camera(100, 100);
            if (near_first) {
                image.draw_mesh(camera, near_one, one_face, blue);
                image.draw_mesh(camera, far_one, one_face, red);
            } else {
                image.draw_mesh(camera, far_one, one_face, red);
                image.draw_mesh(camera, near_one, one_face, blue);
            }
            const Eigen::Vector3i centre = image.pixel(50, 50);
            EXPECT_EQ(centre(0), 0) << "near first: " << near_first;
            EXPECT_GT(centre(2), 0) << "near first: " << near_first;
        }
        // A tilted triangle crossing a flat one: each wins where it is nearer.
        PreviewImage image(100, 100);
        image.clear(white);
        const PreviewCamera camera = axis_camera(100, 100);
        image.draw_mesh(
            camera, triangle(Vec3(-2, -2, 2), Vec3(2, -2, 2), Vec3(0, 2, 2)), one_face, red);
        // Depth 1.5 at x = -0.3 (left) to 2.5 at x = 0.3 (right) along y = 0.
        image.draw_mesh(camera,
            triangle(Vec3(-0.45, -0.6, 1.5), Vec3(0.75, -0.6, 2.5), Vec3(0.15, 0.6, 2.0)), one_face,
            blue);
        EXPECT_GT(image.pixel(45, 52)(2), 0); // left of centre: blue (nearer)
        EXPECT_EQ(image.pixel(45, 52)(0), 0);
        EXPECT_GT(image.pixel(57, 52)(0), 0); // right of centre: red (nearer)
        EXPECT_EQ(image.pixel(57, 52)(2), 0);
    }

    TEST(PreviewImage, FlatShadingIsUniformPerFaceAndBrighterFacingTheLight)
    {
        // Two faces of a box corner: every pixel of a face has the same color.
        PreviewImage image(200, 200);
        image.clear(black);
        const PreviewCamera camera = axis_camera(200, 200);
        image.draw_mesh(camera, triangle(Vec3(-1, -1, 3), Vec3(1, -1, 3), Vec3(-1, 1, 3)), one_face,
            white); // facing the camera
        int distinct = 0;
        Eigen::Vector3i first(-1, -1, -1);
        for (int y = 0; y < 200; ++y)
            for (int x = 0; x < 200; ++x)
                if (image.covered(x, y)) {
                    if (first(0) < 0)
                        first = image.pixel(x, y);
                    distinct += image.pixel(x, y) != first;
                }
        EXPECT_EQ(distinct, 0);
        // The camera light comes from behind the viewer: a face turned 80 degrees away is darker.
        PreviewImage grazing(200, 200);
        grazing.clear(black);
        grazing.draw_mesh(camera,
            triangle(Vec3(-1, -1, 3), Vec3(-1, 1, 3), Vec3(-1 + 0.1, 0, 3 + std::tan(1.396))),
            one_face, white);
        bool found = false;
        for (int y = 0; y < 200 && !found; ++y)
            for (int x = 0; x < 200 && !found; ++x)
                if (grazing.covered(x, y)) {
                    EXPECT_LT(grazing.pixel(x, y)(0), first(0));
                    found = true;
                }
        EXPECT_TRUE(found);
    }

    TEST(PreviewCamera, FramesBoundsInsideTheImage)
    {
        std::mt19937 random(11);
        std::uniform_real_distribution<double> coordinate(-5.0, 5.0), size(0.01, 4.0);
        const Vec3 ups[] = { Vec3::UnitY(), Vec3::UnitZ(), Vec3(0.3, 1.0, -0.2), -Vec3::UnitX() };
        for (int trial = 0; trial < 200; ++trial) {
            const Vec3 lo(coordinate(random), coordinate(random), coordinate(random));
            const Vec3 hi = lo + Vec3(size(random), size(random), size(random));
            const int width = trial % 2 ? 640 : 300, height = trial % 3 ? 480 : 500;
            const PreviewCamera camera = frame_bounds(lo, hi, ups[trial % 4], width, height, 0.1);
            Vec2 min(1e300, 1e300), max(-1e300, -1e300);
            for (int corner = 0; corner < 8; ++corner) {
                const Vec3 p((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                    (corner & 4) ? hi.z() : lo.z());
                const Vec3 s = camera.project(p);
                ASSERT_GT(s.z(), 0.0) << "trial " << trial;
                min = min.cwiseMin(s.head<2>());
                max = max.cwiseMax(s.head<2>());
            }
            // Inside the image with the margin (5% on each side of the centre line)...
            ASSERT_GE(min.x(), 0.05 * width - 1e-6) << "trial " << trial;
            ASSERT_LE(max.x(), 0.95 * width + 1e-6) << "trial " << trial;
            ASSERT_GE(min.y(), 0.05 * height - 1e-6) << "trial " << trial;
            ASSERT_LE(max.y(), 0.95 * height + 1e-6) << "trial " << trial;
            // ...and not lost in it: the box spans at least a third of one side.
            EXPECT_TRUE(max.x() - min.x() > width / 3.0 || max.y() - min.y() > height / 3.0)
                << "trial " << trial;
            // The world's up points up in the image.
            const Vec3 centre = 0.5 * (lo + hi);
            EXPECT_LT(camera.project(centre + 0.1 * ups[trial % 4].normalized()).y(),
                camera.project(centre).y());
        }
    }

    TEST(PreviewImage, GroundPlaneIsDrawnBelowAndHiddenFromBelow)
    {
        const PreviewCamera camera
            = frame_bounds(Vec3(-1, 0, -1), Vec3(1, 2, 1), Vec3::UnitY(), 160, 120, 0.1);
        PreviewImage image(160, 120);
        image.clear(white);
        image.draw_plane(camera, Vec3::Zero(), Vec3::UnitY(), 0.5, Vec3::Zero(), 10.0, white);
        EXPECT_TRUE(image.covered(80, 119)); // the bottom row looks down onto the ground
        EXPECT_FALSE(image.covered(80, 0)); // the top row looks over it
        PreviewImage below(160, 120);
        below.clear(white);
        below.draw_plane(camera, Vec3(0, 50, 0), Vec3::UnitY(), 0.5, Vec3::Zero(), 10.0, white);
        EXPECT_FALSE(below.covered(80, 119));
    }

} // namespace
} // namespace mat
