// The collision check of mat-run --check-collisions: penetration depth of closed surfaces into
// each other (closed-form cube cases, rays through edges and vertices on a surface), the split of
// self pairs by primitive adjacency, and a whole run whose recall on pairs in different bodies
// is 100% in every frame.

#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "runtime/measures/collision_check.hpp"
#include "runtime/run_command.hpp"
#include "tests/runtime/simulation_test_bake.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    /// The axis-aligned cube [lo, lo + size]^3, 12 outward triangles (each face split along a
    /// diagonal, so axis-parallel rays meet the diagonals).
    SurfaceMesh cube(const Vec3& lo, double size)
    {
        SurfaceMesh mesh;
        mesh.positions.resize(8, 3);
        for (int i = 0; i < 8; ++i)
            mesh.positions.row(i)
                = (lo + size * Vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1)).transpose();
        mesh.faces.resize(12, 3);
        mesh.faces << 0, 2, 3, 0, 3, 1, // z = lo
            4, 5, 7, 4, 7, 6, // z = hi
            0, 1, 5, 0, 5, 4, // y = lo
            2, 6, 7, 2, 7, 3, // y = hi
            0, 4, 6, 0, 6, 2, // x = lo
            1, 3, 7, 1, 7, 5; // x = hi
        return mesh;
    }

    TEST(PenetrationDepth, CubeCornersInsideEachOther)
    {
        // Each cube has one corner inside the other, 0.25 from its nearest face.
        const PenetrationDepth depth
            = penetration_depth({ cube(Vec3::Zero(), 1.0), cube(Vec3(0.75, 0.25, 0.25), 1.0) });
        EXPECT_EQ(depth.vertices, 2);
        EXPECT_NEAR(depth.max_depth, 0.25, 1e-15);
    }

    TEST(PenetrationDepth, DeeperAndRaysThroughEdges)
    {
        // A small cube inside a big one: all 8 corners inside; the rays from corners at y = z
        // run along the big cube's face diagonals' plane and through its edges.
        const PenetrationDepth depth
            = penetration_depth({ cube(Vec3::Zero(), 2.0), cube(Vec3(0.5, 0.5, 0.5), 0.5) });
        EXPECT_EQ(depth.vertices, 8);
        EXPECT_NEAR(depth.max_depth, 1.0, 1e-15); // the corner (1, 1, 1) is 1 from every face
    }

    TEST(PenetrationDepth, TouchingAndApartAreNotPenetrating)
    {
        // Corners exactly on the other cube's faces count as outside.
        EXPECT_EQ(penetration_depth({ cube(Vec3::Zero(), 1.0), cube(Vec3(1.0, 0.25, 0.25), 1.0) })
                      .vertices,
            0);
        const PenetrationDepth apart
            = penetration_depth({ cube(Vec3::Zero(), 1.0), cube(Vec3(1.5, 0, 0), 1.0) });
        EXPECT_EQ(apart.vertices, 0);
        EXPECT_EQ(apart.max_depth, 0.0);
        // A single surface is never inside itself.
        EXPECT_EQ(penetration_depth({ cube(Vec3::Zero(), 1.0) }).vertices, 0);
    }

    /// Two cubes as the two parts of one surface: the first cube's vertices in primitive 0, the
    /// second's in primitive 1 (spheres 0 and 1: non-adjacent unless `shared`).
    struct TwoPartSurface {
        SurfaceMesh surface;
        VecXi vertex_primitive;
        MatX3i primitive_spheres;
    };
    TwoPartSurface two_cubes(const Vec3& lo_b, double size_b, bool shared = false)
    {
        const SurfaceMesh a = cube(Vec3::Zero(), 1.0), b = cube(lo_b, size_b);
        TwoPartSurface part;
        part.surface.positions.resize(16, 3);
        part.surface.positions << a.positions, b.positions;
        part.surface.faces.resize(24, 3);
        part.surface.faces << a.faces, (b.faces.array() + 8).matrix();
        part.vertex_primitive.resize(16);
        part.vertex_primitive << VecXi::Zero(8), VecXi::Ones(8);
        part.primitive_spheres.resize(2, 3);
        part.primitive_spheres << 0, -1, -1, (shared ? 0 : 1), -1, -1;
        return part;
    }

    TEST(SelfPenetration, CornerOfOnePartInsideAnother)
    {
        // The second part's corner (0.75, 0.75, 0.75) is 0.25 inside the first (winding number
        // 1/8 of its own cube + 1); the first part's corner (1, 1, 1) is inside the second, 0.25
        // from its faces too. No other vertex is inside.
        const TwoPartSurface part = two_cubes(Vec3(0.75, 0.75, 0.75), 1.0);
        const PenetrationDepth depth
            = self_penetration_depth(part.surface, part.vertex_primitive, part.primitive_spheres);
        EXPECT_EQ(depth.vertices, 2);
        EXPECT_NEAR(depth.max_depth, 0.25, 1e-12);
        // Deeper: a small cube wholly inside; all 8 of its corners, the deepest 0.4 from a face.
        const TwoPartSurface inner = two_cubes(Vec3(0.4, 0.4, 0.4), 0.2);
        const PenetrationDepth all = self_penetration_depth(
            inner.surface, inner.vertex_primitive, inner.primitive_spheres);
        EXPECT_EQ(all.vertices, 8);
        EXPECT_NEAR(all.max_depth, 0.4, 1e-12);
    }

    TEST(SelfPenetration, EmbeddedAndApartPartsAreNotInside)
    {
        // Apart, and touching face to face: no vertex is inside the body.
        for (const Vec3& lo : { Vec3(1.5, 0.0, 0.0), Vec3(1.0, 0.25, 0.25) }) {
            const TwoPartSurface part = two_cubes(lo, 1.0);
            EXPECT_EQ(
                self_penetration_depth(part.surface, part.vertex_primitive, part.primitive_spheres)
                    .vertices,
                0)
                << lo.transpose();
        }
        // One closed cube alone: every corner has winding number 1/8.
        const SurfaceMesh one = cube(Vec3::Zero(), 1.0);
        EXPECT_EQ(
            self_penetration_depth(one, VecXi::Zero(8), MatX3i::Constant(1, 3, -1)).vertices, 0);
    }

    TEST(SelfPenetration, EnclosedOnlyByAnAdjacentPartIsNotCounted)
    {
        // The small cube wholly inside the big one (winding number 1 + 1/8 at its corners), the
        // two parts adjacent (their primitives share a sphere): a fold of adjacent parts, which
        // the check does not look for; no far face winds around the corners, none counts. The
        // same cubes in non-adjacent parts count (SelfPenetration.CornerOfOnePartInsideAnother).
        const TwoPartSurface folded = two_cubes(Vec3(0.4, 0.4, 0.4), 0.2, true);
        const PenetrationDepth depth = self_penetration_depth(
            folded.surface, folded.vertex_primitive, folded.primitive_spheres);
        EXPECT_EQ(depth.vertices, 0);
        EXPECT_EQ(depth.max_depth, 0.0);
    }

    TEST(CollisionCheck, SelfPairsSplitByPrimitiveAdjacency)
    {
        // Primitives: 0 = cone (spheres 0, 1), 1 = cone (1, 2), 2 = sphere 3.
        MatX3i spheres(3, 3);
        spheres << 0, 1, -1, 1, 2, -1, 3, -1, -1;
        // Vertices 0-2 in primitive 0, 3-5 in 1, 6-8 in 2; vertex 9 in 0, 10 in 2.
        VecXi vertex_primitive(11);
        vertex_primitive << 0, 0, 0, 1, 1, 1, 2, 2, 2, 0, 2;
        MatX3i faces(5, 3);
        faces << 0, 1, 2, 3, 4, 5, 6, 7, 8, 0, 9, 1, 3, 4, 10;
        // Same primitive, adjacent primitives: near.
        EXPECT_FALSE(faces_in_non_adjacent_primitives(faces, vertex_primitive, spheres, 0, 3));
        EXPECT_FALSE(faces_in_non_adjacent_primitives(faces, vertex_primitive, spheres, 0, 1));
        // No shared sphere: far; also when only one vertex of a face is in such a primitive.
        EXPECT_TRUE(faces_in_non_adjacent_primitives(faces, vertex_primitive, spheres, 0, 2));
        EXPECT_TRUE(faces_in_non_adjacent_primitives(faces, vertex_primitive, spheres, 1, 2));
        EXPECT_TRUE(faces_in_non_adjacent_primitives(faces, vertex_primitive, spheres, 0, 4));
        EXPECT_EQ(recall(0, 0), 1.0);
        EXPECT_EQ(recall(3, 4), 0.75);
    }

    using CollisionCheckRun = test::ScratchDirTest;

    TEST_F(CollisionCheckRun, EveryPairInDifferentBodiesIsFoundInEveryFrame)
    {
        // One capsule dropped across another resting on the ground.
        test::write_capsule_bake(path("capsule.h5"));
        RunOptions options;
        options.scene = write_text("scene.json", R"({
            "time": {"dt": 0.02, "frames": 12, "iterations": 5},
            "solver": {"collision": "bounded"},
            "objects": [
                {"name": "bottom", "bake": "capsule.h5", "position": [0, 0.12, 0]},
                {"name": "top", "bake": "capsule.h5", "position": [0.05, 0.32, 0],
                 "rotation_degrees": [0, 70, 0], "velocity": [0, -1.5, 0]}],
            "colliders": [{"type": "plane"}]})");
        options.output = path("out");
        options.stats = path("stats.json");
        options.check_collisions = true;
        run_simulation(options);
        std::ifstream in(options.stats);
        const nlohmann::json stats = nlohmann::json::parse(in);
        long far_pairs = 0;
        for (const auto& frame : stats["frames"]) {
            if (frame["frame"] == 0) {
                EXPECT_FALSE(frame.contains("collision_check"));
                continue;
            }
            const auto& check = frame["collision_check"];
            SCOPED_TRACE(frame["frame"].get<int>());
            EXPECT_EQ(check["far_found"], check["far_pairs"]);
            EXPECT_EQ(check["far_recall"], 1.0);
            EXPECT_EQ(check["extra"], 0);
            EXPECT_GE(check["max_penetration"].get<double>(), 0.0);
            far_pairs += check["far_pairs"].get<long>();
        }
        EXPECT_GT(far_pairs, 0); // the capsules did intersect somewhere
        EXPECT_EQ(stats["collision_check"]["far_pairs"], far_pairs);
        EXPECT_EQ(stats["collision_check"]["steps"], 12);
    }

    TEST_F(CollisionCheckRun, NeedsCollisionOn)
    {
        test::write_capsule_bake(path("capsule.h5"));
        // One object without self collision, and two with collision off.
        for (const char* text :
            { R"({"solver": {"self_collision": "off"}, "objects": [{"bake": "capsule.h5"}]})",
                R"({"solver": {"collision": "off"},
                    "objects": [{"bake": "capsule.h5"}, {"bake": "capsule.h5"}]})" }) {
            SCOPED_TRACE(text);
            RunOptions options;
            options.scene = write_text("scene.json", text);
            options.output = path("out");
            options.check_collisions = true;
            try {
                run_simulation(options);
                FAIL() << "no error";
            } catch (const Error& e) {
                EXPECT_NE(std::string(e.what()).find("--check-collisions: "), std::string::npos)
                    << e.what();
                EXPECT_NE(std::string(e.what()).find("has no collision between objects to check"),
                    std::string::npos)
                    << e.what();
            }
            EXPECT_FALSE(std::filesystem::exists(path("out")));
        }
    }

} // namespace
} // namespace mat
