#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include "common/error.hpp"
#include "formats/atomic_file.hpp"
#include "formats/hdf5_file.hpp"
#include "formats/trajectory_io.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/random_data.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using Trajectory = test::ScratchDirTest;
    using test::expect_error_containing;

    using test::random_positions;

    /// Two objects, named so that alphabetical order differs from the scene's order.
    std::vector<TrajectoryObject> two_objects()
    {
        TrajectoryObject zeta { "zeta", MatX3i(2, 3), random_positions(4, 1) };
        zeta.faces << 0, 1, 2, 0, 2, 3;
        TrajectoryObject alpha { "alpha", MatX3i(1, 3), random_positions(3, 2) };
        alpha.faces << 2, 1, 0;
        return { zeta, alpha };
    }

    /// Frame `frame` of the objects: their rest positions moved and scaled by the frame.
    std::vector<MatX3> frame_values(
        const std::vector<TrajectoryObject>& objects, int frame, double scale)
    {
        std::vector<MatX3> out;
        for (std::size_t i = 0; i < objects.size(); ++i)
            out.push_back(scale
                * (objects[i].rest_positions
                    + random_positions(
                        objects[i].rest_positions.rows(), unsigned(100 * frame + i))));
        return out;
    }

    const std::vector<double> times { 0.0, 0.01, 0.025 };

    void write_three_frames(const std::string& file, bool with_velocities)
    {
        const auto objects = two_objects();
        TrajectoryWriter writer(file, objects, R"({"dt": 0.01})");
        for (int f = 0; f < 3; ++f) {
            const std::vector<MatX3> velocities = frame_values(objects, f, -2.0);
            writer.append(times[std::size_t(f)], frame_values(objects, f, 1.0),
                with_velocities ? &velocities : nullptr);
        }
        EXPECT_EQ(writer.frame_count(), 3);
        writer.commit();
    }

    TEST_F(Trajectory, TwoObjectsThreeFramesRoundTrip)
    {
        const std::string file = path("run.h5");
        write_three_frames(file, true);
        const auto objects = two_objects();
        const TrajectoryReader reader(file);
        EXPECT_EQ(reader.version(), trajectory_format_version);
        EXPECT_EQ(reader.options(), R"({"dt": 0.01})");
        ASSERT_EQ(reader.frame_count(), 3);
        for (int f = 0; f < 3; ++f)
            EXPECT_EQ(reader.times()[f], times[std::size_t(f)]);
        EXPECT_EQ(reader.object_names(), (std::vector<std::string> { "zeta", "alpha" }));
        EXPECT_EQ(reader.object_index("alpha"), 1);
        ASSERT_TRUE(reader.has_velocities());
        for (Index o = 0; o < 2; ++o) {
            EXPECT_EQ(reader.vertex_count(o), objects[std::size_t(o)].rest_positions.rows());
            EXPECT_EQ(reader.faces(o), objects[std::size_t(o)].faces);
            EXPECT_EQ(reader.rest_positions(o), objects[std::size_t(o)].rest_positions);
            for (int f = 0; f < 3; ++f) {
                EXPECT_EQ(reader.positions(o, f), frame_values(objects, f, 1.0)[std::size_t(o)]);
                EXPECT_EQ(reader.velocities(o, f), frame_values(objects, f, -2.0)[std::size_t(o)]);
            }
        }
        // The layout is what the header documents (h5py users read it directly).
        const H5Reader raw(file);
        EXPECT_EQ(raw.shape("objects/zeta/positions"), (std::vector<Index> { 3, 4, 3 }));
        EXPECT_EQ(raw.read_string_attribute("/", "format_name"), "medial-elastics-trajectory");

        expect_error_containing([&] { reader.positions(0, 3); }, { file, "frame 3" });
        expect_error_containing([&] { reader.faces(2); }, { file, "object 2" });
        expect_error_containing([&] { reader.object_index("beta"); }, { file, "'beta'", "zeta" });
    }

    TEST_F(Trajectory, WithoutVelocitiesAndByteDeterministic)
    {
        write_three_frames(path("a.h5"), false);
        write_three_frames(path("b.h5"), false);
        const std::string bytes = test::read_file_contents(path("a.h5"));
        EXPECT_FALSE(bytes.empty());
        EXPECT_EQ(bytes, test::read_file_contents(path("b.h5")));
        const TrajectoryReader reader(path("a.h5"));
        EXPECT_FALSE(reader.has_velocities());
        EXPECT_EQ(reader.positions(1, 2), frame_values(two_objects(), 2, 1.0)[1]);
        expect_error_containing([&] { reader.velocities(0, 0); }, { path("a.h5"), "velocities" });
    }

    TEST_F(Trajectory, ManyFramesCrossChunkBoundaries)
    {
        TrajectoryObject object { "body", MatX3i(0, 3), random_positions(50, 9) };
        {
            TrajectoryWriter writer(path("long.h5"), { object });
            for (int f = 0; f < 150; ++f)
                writer.append(0.5 * f, { MatX3::Constant(50, 3, double(f)) });
            writer.commit();
        }
        const TrajectoryReader reader(path("long.h5"));
        ASSERT_EQ(reader.frame_count(), 150);
        for (int f : { 0, 63, 64, 65, 127, 128, 149 }) {
            EXPECT_EQ(reader.times()[f], 0.5 * f);
            EXPECT_EQ(reader.positions(0, f), MatX3::Constant(50, 3, double(f)));
        }
    }

    TEST_F(Trajectory, WithoutCommitNothingIsLeft)
    {
        const std::string file = path("run.h5");
        write_three_frames(file, false);
        const std::string before = test::read_file_contents(file);
        {
            const auto objects = two_objects();
            TrajectoryWriter writer(file, objects);
            writer.append(0.0, frame_values(objects, 0, 1.0));
            EXPECT_EQ(num_entries(), 2u); // the temporary, beside the old file
        } // an aborted run
        EXPECT_EQ(num_entries(), 1u);
        EXPECT_EQ(test::read_file_contents(file), before);

        const std::string missing = path("no_such_dir/run.h5");
        expect_error_containing([&] { TrajectoryWriter writer(missing, two_objects()); },
            { missing, "does not exist" });
        EXPECT_EQ(num_entries(), 1u);
    }

    TEST_F(Trajectory, WriterRejectsBadInputAndStaysUsable)
    {
        const std::string file = path("run.h5");
        auto objects = two_objects();
        objects[1].name = "zeta";
        expect_error_containing(
            [&] { TrajectoryWriter writer(file, objects); }, { file, "two objects", "'zeta'" });
        objects[1].name = "a/b";
        expect_error_containing([&] { TrajectoryWriter writer(file, objects); }, { file, "'a/b'" });
        objects = two_objects();
        objects[0].faces(1, 2) = 4;
        expect_error_containing([&] { TrajectoryWriter writer(file, objects); },
            { file, "'zeta'", "face 1 has vertex index 4" });
        EXPECT_EQ(num_entries(), 0u);

        objects = two_objects();
        TrajectoryWriter writer(file, objects);
        const std::vector<MatX3> good = frame_values(objects, 0, 1.0);
        expect_error_containing([&] { writer.append(0.0, { good[0] }); },
            { file, "frame 0", "1 arrays of positions", "(2)" });
        std::vector<MatX3> bad = good;
        bad[1] = MatX3::Zero(5, 3);
        expect_error_containing([&] { writer.append(0.0, bad); },
            { file, "positions of '/objects/alpha' has 5 rows, expected 3" });
        bad = good;
        bad[0](2, 1) = std::nan("");
        expect_error_containing(
            [&] { writer.append(0.0, bad); }, { file, "not finite at vertex 2" });
        writer.append(0.0, good);
        expect_error_containing(
            [&] { writer.append(0.0, good); }, { file, "frame 1", "not after" });
        expect_error_containing(
            [&] { writer.append(1.0, good, &good); }, { file, "earlier frames have none" });
        writer.append(1.0, good);
        writer.commit();
        EXPECT_EQ(TrajectoryReader(file).frame_count(), 2);
    }

    TEST_F(Trajectory, ReaderChecksTheFormatStamp)
    {
        {
            H5Writer other(path("bake.h5"));
            other.stamp_format("medial-elastics-bake", 1);
            other.commit();
            H5Writer none(path("none.h5"));
            none.write_vector("time", Eigen::VectorXd::Zero(2));
            none.commit();
            H5Writer newer(path("newer.h5"));
            newer.stamp_format(trajectory_format_name, trajectory_format_version + 1);
            newer.commit();
        }
        expect_error_containing([&] { TrajectoryReader reader(path("bake.h5")); },
            { path("bake.h5"), "medial-elastics-bake", "medial-elastics-trajectory" });
        expect_error_containing(
            [&] { TrajectoryReader reader(path("none.h5")); }, { path("none.h5"), "format_name" });
        expect_error_containing([&] { TrajectoryReader reader(path("newer.h5")); },
            { path("newer.h5"), fmt::format("version {}", trajectory_format_version + 1) });
        expect_error_containing([&] { TrajectoryReader reader(path("absent.h5")); },
            { path("absent.h5"), "no such file" });
    }

    TEST_F(Trajectory, ReaderNamesTheInconsistentDataset)
    {
        // A stamped file whose positions have fewer frames than /time.
        {
            H5Writer out(path("bad.h5"));
            out.stamp_format(trajectory_format_name, trajectory_format_version);
            out.set_attribute("/", "frame_count", std::int64_t(2));
            out.create_series("time", {});
            out.append("time", 0.0);
            out.append("time", 1.0);
            out.create_group("objects/body");
            out.set_attribute("objects/body", "index", 0);
            out.write_matrix("objects/body/faces", MatX3i::Zero(1, 3));
            out.write_matrix("objects/body/rest_positions", MatX3::Zero(2, 3));
            out.create_series("objects/body/positions", { 2, 3 });
            out.append("objects/body/positions", MatX3::Zero(2, 3));
            out.commit();
        }
        expect_error_containing([&] { TrajectoryReader reader(path("bad.h5")); },
            { path("bad.h5"), "'/objects/body/positions'", "1 x 2 x 3", "2 x 2 x 3" });
    }

    // A reserved trajectory (the one mat-run writes) whose writer is killed with SIGKILL after
    // `frames` appends, in a child process: the file must hold exactly those frames.
    TEST_F(Trajectory, ReservedFileKeepsTheFramesOfAKilledWriter)
    {
        const std::string file = path("killed.h5");
        const auto objects = two_objects();
        constexpr int frames = 5;
        const pid_t child = fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            TrajectoryWriter writer(
                file, objects, "{}", H5WriterOptions {}, TrajectoryLayout { 40, true });
            writer.publish();
            for (int f = 0; f < frames; ++f) {
                const std::vector<MatX3> velocities = frame_values(objects, f, -2.0);
                writer.append(0.01 * f, frame_values(objects, f, 1.0), &velocities);
            }
            raise(SIGKILL);
        }
        int status = 0;
        ASSERT_EQ(waitpid(child, &status, 0), child);
        ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
        const TrajectoryReader reader(file);
        ASSERT_EQ(reader.frame_count(), frames);
        ASSERT_TRUE(reader.has_velocities());
        for (int f = 0; f < frames; ++f) {
            EXPECT_EQ(reader.times()[f], 0.01 * f);
            for (Index o = 0; o < 2; ++o) {
                EXPECT_EQ(reader.positions(o, f), frame_values(objects, f, 1.0)[std::size_t(o)]);
                EXPECT_EQ(reader.velocities(o, f), frame_values(objects, f, -2.0)[std::size_t(o)]);
            }
        }
        expect_error_containing([&] { reader.positions(0, frames); }, { "frame 5 does not exist" });
        // Copied into a new file (what --resume does), then completed.
        TrajectoryWriter rebuilt(
            path("rebuilt.h5"), objects, "{}", H5WriterOptions {}, TrajectoryLayout { 6, true });
        copy_frames(reader, rebuilt, 3);
        EXPECT_EQ(rebuilt.frame_count(), 3);
        rebuilt.publish();
        const std::vector<MatX3> velocities = frame_values(objects, 3, -2.0);
        for (int f = 3; f < 6; ++f)
            rebuilt.append(0.01 * f, frame_values(objects, f, 1.0), &velocities);
        EXPECT_EQ(rebuilt.frame_count(), 6);
        expect_error_containing(
            [&] { rebuilt.append(1.0, frame_values(objects, 6, 1.0), &velocities); },
            { "6 frames were reserved" });
    }

    TEST_F(Trajectory, StaleTemporariesOfDeadProcessesAreRemoved)
    {
        const pid_t child = fork();
        ASSERT_GE(child, 0);
        if (child == 0)
            _exit(0);
        ASSERT_EQ(waitpid(child, nullptr, 0), child);
        const std::string dead = path(fmt::format(".trajectory.h5.{}.0.tmp", child));
        const std::string mine = path(fmt::format(".trajectory.h5.{}.3.tmp", getpid()));
        const std::string other = path(fmt::format(".stats.json.{}.0.tmp", child));
        const std::string unrelated = path(".notes.tmp");
        for (const std::string& f : { dead, mine, other, unrelated })
            std::ofstream(f) << "x";
        EXPECT_EQ(remove_stale_temporaries(dir().string(), "trajectory.h5"), 1);
        EXPECT_FALSE(std::filesystem::exists(dead));
        EXPECT_TRUE(std::filesystem::exists(other));
        EXPECT_EQ(remove_stale_temporaries(dir().string()), 1);
        EXPECT_FALSE(std::filesystem::exists(other));
        EXPECT_TRUE(std::filesystem::exists(mine)); // this process may be writing it
        EXPECT_TRUE(std::filesystem::exists(unrelated));
    }

} // namespace
} // namespace mat
