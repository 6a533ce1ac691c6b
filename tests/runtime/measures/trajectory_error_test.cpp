#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "formats/trajectory_io.hpp"
#include "runtime/measures/trajectory_error.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/random_data.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using TrajectoryErrorTest = test::ScratchDirTest;
    using test::expect_error_containing;
    using test::random_positions;

    /// Two objects whose rest positions together span the box [0, 3] x [0, 4] x [0, 12]
    /// (diagonal 13).
    std::vector<TrajectoryObject> two_objects()
    {
        TrajectoryObject a { "a", MatX3i(1, 3), MatX3(3, 3) };
        a.faces << 0, 1, 2;
        a.rest_positions << 0, 0, 0, 3, 0, 0, 0, 4, 0;
        TrajectoryObject b { "b", MatX3i(1, 3), MatX3(4, 3) };
        b.faces << 0, 1, 3;
        b.rest_positions << 0, 0, 12, 1, 1, 1, 2, 2, 2, 1, 0, 1;
        return { a, b };
    }

    /// Frame f: the rest positions plus seeded noise (the same for the same f).
    std::vector<MatX3> frame_positions(const std::vector<TrajectoryObject>& objects, int f)
    {
        std::vector<MatX3> out;
        for (std::size_t i = 0; i < objects.size(); ++i)
            out.push_back(objects[i].rest_positions
                + 0.1 * random_positions(objects[i].rest_positions.rows(), unsigned(10 * f + i)));
        return out;
    }

    /// Writes `times.size()` frames of `objects`; object `moved` (if >= 0) gets `offset` added at
    /// frame `moved_frame`, at vertex `moved_vertex` only if that is >= 0.
    void write(const std::string& path, const std::vector<TrajectoryObject>& objects,
        const std::vector<double>& times, int moved = -1, int moved_frame = 0,
        int moved_vertex = -1, const Vec3& offset = Vec3::Zero())
    {
        TrajectoryWriter writer(path, objects);
        for (std::size_t f = 0; f < times.size(); ++f) {
            std::vector<MatX3> x = frame_positions(objects, int(f));
            if (moved >= 0 && int(f) == moved_frame) {
                MatX3& m = x[std::size_t(moved)];
                for (Index v = 0; v < m.rows(); ++v)
                    if (moved_vertex < 0 || v == moved_vertex)
                        m.row(v) += offset.transpose();
            }
            writer.append(times[f], x);
        }
        writer.commit();
    }

    const std::vector<double> times { 0.0, 0.1, 0.2 };

    TEST_F(TrajectoryErrorTest, IdenticalFilesHaveZeroError)
    {
        write(path("run.h5"), two_objects(), times);
        write(path("ref.h5"), two_objects(), times);
        const TrajectoryError e = trajectory_error(path("run.h5"), path("ref.h5"));
        EXPECT_DOUBLE_EQ(e.diagonal, 13.0);
        EXPECT_EQ(e.rms_percent, 0.0);
        EXPECT_EQ(e.max_percent, 0.0);
        ASSERT_EQ(e.times.size(), 3);
        ASSERT_EQ(e.frame_rms_percent.size(), 3);
        EXPECT_EQ(e.frame_max_percent.size(), 3);
        EXPECT_EQ(e.times(2), 0.2);
    }

    TEST_F(TrajectoryErrorTest, KnownOffsetGivesTheExactPercentages)
    {
        // One vertex of object b moved by (0, 0.39, 0.52) (length 0.65 = 5% of 13) at frame 1:
        // frame 1 max 5%, RMS 5% / sqrt(7) (7 vertices in all); the other frames 0.
        write(path("ref.h5"), two_objects(), times);
        write(path("run.h5"), two_objects(), times, 1, 1, 2, Vec3(0.0, 0.39, 0.52));
        const TrajectoryError e = trajectory_error(path("run.h5"), path("ref.h5"));
        EXPECT_NEAR(e.max_percent, 5.0, 1e-12);
        EXPECT_NEAR(e.rms_percent, 5.0 / std::sqrt(7.0), 1e-12);
        EXPECT_EQ(e.frame_max_percent(0), 0.0);
        EXPECT_NEAR(e.frame_max_percent(1), 5.0, 1e-12);
        EXPECT_EQ(e.frame_max_percent(2), 0.0);
        EXPECT_EQ(e.frame_rms_percent(2), 0.0);
    }

    TEST_F(TrajectoryErrorTest, MaxOverFramesOfRmsAndMaxAreTakenSeparately)
    {
        // Every vertex of a moved by 1.3 (10%) at frame 2: RMS sqrt(3/7) * 10%, max 10%.
        write(path("ref.h5"), two_objects(), times);
        write(path("run.h5"), two_objects(), times, 0, 2, -1, Vec3(1.3, 0.0, 0.0));
        const TrajectoryError e = trajectory_error(path("run.h5"), path("ref.h5"));
        EXPECT_NEAR(e.max_percent, 10.0, 1e-12);
        EXPECT_NEAR(e.rms_percent, 10.0 * std::sqrt(3.0 / 7.0), 1e-12);
        EXPECT_NEAR(e.frame_rms_percent(2), e.rms_percent, 1e-15);
    }

    TEST_F(TrajectoryErrorTest, ObjectOrderDoesNotMatter)
    {
        auto objects = two_objects();
        write(path("ref.h5"), objects, times);
        // The run holds b first, with the same positions frame by frame.
        {
            const std::vector<TrajectoryObject> swapped { objects[1], objects[0] };
            TrajectoryWriter writer(path("run.h5"), swapped);
            for (std::size_t f = 0; f < times.size(); ++f) {
                const std::vector<MatX3> x = frame_positions(objects, int(f));
                writer.append(times[f], { x[1], x[0] });
            }
            writer.commit();
        }
        const TrajectoryError e = trajectory_error(path("run.h5"), path("ref.h5"));
        EXPECT_EQ(e.max_percent, 0.0);
    }

    TEST_F(TrajectoryErrorTest, MismatchesAreOneLineErrors)
    {
        write(path("ref.h5"), two_objects(), times);

        auto renamed = two_objects();
        renamed[1].name = "c";
        write(path("renamed.h5"), renamed, times);
        expect_error_containing([&] { trajectory_error(path("renamed.h5"), path("ref.h5")); },
            { "renamed.h5", "object 'c' is not in the reference" });

        auto fewer_vertices = two_objects();
        fewer_vertices[1].rest_positions.conservativeResize(3, 3);
        fewer_vertices[1].faces << 0, 1, 2;
        write(path("vertices.h5"), fewer_vertices, times);
        expect_error_containing([&] { trajectory_error(path("vertices.h5"), path("ref.h5")); },
            { "vertices.h5", "object 'b' has 3 surface vertices", "has 4" });

        auto one_object = two_objects();
        one_object.pop_back();
        write(path("one.h5"), one_object, times);
        expect_error_containing([&] { trajectory_error(path("one.h5"), path("ref.h5")); },
            { "one.h5", "no object 'b'" });

        write(path("frames.h5"), two_objects(), { 0.0, 0.1 });
        expect_error_containing([&] { trajectory_error(path("frames.h5"), path("ref.h5")); },
            { "frames.h5", "2 frames", "has 3" });

        write(path("times.h5"), two_objects(), { 0.0, 0.1, 0.25 });
        expect_error_containing([&] { trajectory_error(path("times.h5"), path("ref.h5")); },
            { "times.h5", "frame 2 is at time 0.25 s" });

        expect_error_containing(
            [&] { trajectory_error(path("missing.h5"), path("ref.h5")); }, { "missing.h5" });
    }

    TEST_F(TrajectoryErrorTest, CheckReferenceBeforeARun)
    {
        write(path("ref.h5"), two_objects(), times);
        const TrajectoryReader reference(path("ref.h5"));
        EXPECT_NO_THROW(check_reference(reference, { "b", "a" }, { 4, 3 }, 3));
        expect_error_containing(
            [&] {
                check_reference(reference, { "a", "c" }, { 3, 4 }, 3);
            },
            { "ref.h5", "no object 'c'" });
        expect_error_containing(
            [&] {
                check_reference(reference, { "a", "b" }, { 3, 5 }, 3);
            },
            { "ref.h5", "object 'b' has 4 surface vertices in the reference, 5 in this run" });
        expect_error_containing([&] { check_reference(reference, { "a" }, { 3 }, 3); },
            { "ref.h5", "the reference has 2 objects, this run 1" });
        expect_error_containing(
            [&] {
                check_reference(reference, { "a", "b" }, { 3, 4 }, 4);
            },
            { "ref.h5", "the reference has 3 frames, this run writes 4" });
    }

    TEST_F(TrajectoryErrorTest, MessagesAreOneLine)
    {
        write(path("ref.h5"), two_objects(), times);
        write(path("times.h5"), two_objects(), { 0.0, 0.1, 0.25 });
        try {
            trajectory_error(path("times.h5"), path("ref.h5"));
            ADD_FAILURE() << "no error";
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
        }
    }

} // namespace
} // namespace mat
