#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/tet_geometry.hpp"
#include "formats/tet_mesh_io.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"
#include "tests/support/text_mutation.hpp"

namespace mat {
namespace {

    namespace fs = std::filesystem;

    using TetMeshIo = test::ScratchDirTest;

    using test::expect_line_error;

    void expect_medit_error(const std::string& text, int line, const std::string& what)
    {
        expect_line_error([&] { read_medit_from_string(text, "t.mesh"); }, "t.mesh", line, what);
    }

    void expect_node_error(const std::string& node, int line, const std::string& what)
    {
        const std::string ele = "1 4 0\n0 0 1 2 3\n";
        expect_line_error(
            [&] { read_tetgen_from_strings(node, "t.node", ele, "t.ele"); }, "t.node", line, what);
    }

    void expect_ele_error(const std::string& ele, int line, const std::string& what)
    {
        const std::string node = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
        expect_line_error(
            [&] { read_tetgen_from_strings(node, "t.node", ele, "t.ele"); }, "t.ele", line, what);
    }

    void expect_equal(const TetMesh& a, const TetMesh& b)
    {
        ASSERT_EQ(a.num_vertices(), b.num_vertices());
        ASSERT_EQ(a.num_tets(), b.num_tets());
        EXPECT_TRUE(a.positions == b.positions); // bit for bit
        EXPECT_TRUE(a.tets == b.tets);
    }

    // A jittered unit cube cut into 5 positively oriented tets.
    TetMesh cube(unsigned seed)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> jitter(-0.05, 0.05);
        TetMesh mesh;
        mesh.positions.resize(8, 3);
        for (int i = 0; i < 8; ++i)
            mesh.positions.row(i) << (i & 1) + jitter(rng), ((i >> 1) & 1) + jitter(rng),
                ((i >> 2) & 1) + jitter(rng);
        mesh.positions(0, 0) = 0.1 + 0.2; // needs 17 digits
        mesh.tets.resize(5, 4);
        mesh.tets << 0, 1, 2, 4, 1, 3, 2, 7, 1, 4, 5, 7, 2, 7, 4, 6, 1, 2, 4, 7;
        for (Index t = 0; t < mesh.num_tets(); ++t)
            if (tet_orientation(mesh, t) < 0)
                std::swap(mesh.tets(t, 2), mesh.tets(t, 3));
        return mesh;
    }

    // ---- Round trips ----------------------------------------------------------------------

    TEST_F(TetMeshIo, RoundTripMeditAndTetGen)
    {
        const TetMesh mesh = cube(5);
        for (Index t = 0; t < mesh.num_tets(); ++t)
            ASSERT_GT(tet_orientation(mesh, t), 0.0);
        write_tet_mesh(path("cube.mesh"), mesh);
        expect_equal(read_tet_mesh(path("cube.mesh")), mesh);
        write_tet_mesh(path("cube.node"), mesh);
        EXPECT_TRUE(fs::exists(path("cube.ele")));
        expect_equal(read_tet_mesh(path("cube.ele")), mesh);
        expect_equal(read_tetgen(path("cube")), mesh);
        write_tet_mesh(path("other.ELE"), mesh);
        expect_equal(read_tet_mesh(path("other.node")), mesh);
        EXPECT_EQ(num_entries(), 5u); // no temporaries left
    }

    TEST_F(TetMeshIo, UnknownExtension)
    {
        EXPECT_THROW(read_tet_mesh(path("x.obj")), Error);
        EXPECT_THROW(write_tet_mesh(path("x.vtk"), cube(1)), Error);
        EXPECT_THROW(read_tet_mesh(path("absent.mesh")), Error);
        EXPECT_EQ(num_entries(), 0u);
    }

    // ---- Medit ----------------------------------------------------------------------------

    TEST(Medit, SkipsOtherSectionsAndAcceptsFreeLayout)
    {
        const std::string text = "# written by hand\n"
                                 "MeshVersionFormatted\n1\n\nDimension\n3\n"
                                 "Vertices\n5\n"
                                 "0 0 0 1\n1 0 0 1\n0 1 0 0\n0 0 1 0\n1 1 1 2\n"
                                 "Edges 1\n1 2 0\n"
                                 "Triangles\n2\n1 2 3 7\n1 3 4 7\n"
                                 "Corners 2\n1\n2\n"
                                 "Normals 1\n0 0 1\n"
                                 "NormalAtVertices 1\n1 1\n"
                                 "Tetrahedra\n2\n"
                                 "1 2 3 4 0\n"
                                 "2 4 3 5 3 # comment\n"
                                 "Identifier\n\"some name\"\n"
                                 "End\n";
        const TetMesh mesh = read_medit_from_string(text, "t.mesh");
        ASSERT_EQ(mesh.num_vertices(), 5);
        ASSERT_EQ(mesh.num_tets(), 2);
        EXPECT_EQ(mesh.positions(4, 2), 1.0);
        EXPECT_TRUE(mesh.tets.row(0) == Eigen::RowVector4i(0, 1, 2, 3));
        // The second tet is negatively oriented as written: its last two indices are swapped.
        EXPECT_TRUE(mesh.tets.row(1) == Eigen::RowVector4i(1, 3, 4, 2)) << mesh.tets;
        EXPECT_GT(tet_orientation(mesh, 1), 0.0);
    }

    const std::string medit_head = "MeshVersionFormatted 2\nDimension 3\nVertices\n4\n"
                                   "0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n"; // lines 1..8

    TEST(Medit, RejectsBrokenInput)
    {
        expect_medit_error("", 1, "empty file");
        expect_medit_error(
            "Dimension 3\n", 1, "expected 'MeshVersionFormatted', found 'Dimension'");
        expect_medit_error("MeshVersionFormatted 9\n", 1, "unsupported MeshVersionFormatted 9");
        expect_medit_error("MeshVersionFormatted 1\nDimension 2\n", 2, "Dimension 2");
        expect_medit_error("MeshVersionFormatted 1\nDimension\nthree\n", 3,
            "'Dimension' must be followed by a non-negative integer, found 'three'");
        expect_medit_error("MeshVersionFormatted 1\nVertices 0\n", 2, "Vertices before");
        expect_medit_error(medit_head + "Tetras 1\n", 9, "unknown keyword 'Tetras'");
        expect_medit_error(
            medit_head + "Tetrahedra 1 2\n", 9, "unexpected '2' after 'Tetrahedra' 1");
        // Vertices
        expect_medit_error("MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n1 0 0\n", 6,
            "wrong number of fields: a Vertices entry needs 4 values (x y z ref), found 3");
        expect_medit_error("MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n1 y 0 0\n",
            6, "value 'y' of field 'y' is not a number");
        expect_medit_error(
            "MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n1 0 -inf 0\n", 6,
            "value '-inf' of field 'z' is not finite");
        expect_medit_error("MeshVersionFormatted 2\nDimension 3\nVertices\n3\n0 0 0 0\n", 6,
            "end of file in the Vertices section: 1 of its 3 entries read");
        expect_medit_error(medit_head + "Vertices 0\n", 9, "a second Vertices section");
        // Tetrahedra
        expect_medit_error(medit_head + "Tetrahedra\n1\n1 2 3 5 0\nEnd\n", 11,
            "vertex index 5 out of range: the mesh has 4 vertices");
        expect_medit_error(medit_head + "Tetrahedra\n1\n0 1 2 3 0\nEnd\n", 11,
            "vertex index 0 out of range: Medit indices start at 1");
        expect_medit_error(medit_head + "Tetrahedra\n1\n1 2 2 3 0\nEnd\n", 11,
            "degenerate tet: vertex index 2 is repeated");
        expect_medit_error(medit_head + "Tetrahedra\n1\n1 2 3 4.5 0\nEnd\n", 11,
            "vertex index '4.5' is not an integer");
        expect_medit_error(
            medit_head + "Tetrahedra\n1\n1 2 3 4\nEnd\n", 11, "a Tetrahedra entry needs 5 values");
        expect_medit_error(medit_head + "Tetrahedra\n2\n1 2 3 4 0\nEnd\n", 12,
            "the Tetrahedra section ends at 'End' after 1 of its 2 entries");
        expect_medit_error(
            medit_head + "Triangles\n1\n1 2 0\nEnd\n", 11, "a Triangles entry needs 4 values");
        // Structure
        expect_medit_error(medit_head + "Tetrahedra\n1\n1 2 3 4 0\n", 12, "missing 'End'");
        expect_medit_error(medit_head + "End\n", 9, "no Tetrahedra section");
        expect_medit_error("MeshVersionFormatted 2\nDimension 3\nEnd\n", 3, "no Vertices section");
    }

    TEST_F(TetMeshIo, ReadMeditNamesTheFile)
    {
        const std::string p
            = write_text("bad.mesh", medit_head + "Tetrahedra\n1\n1 2 3 9 0\nEnd\n");
        expect_line_error([&] { read_tet_mesh(p); }, p, 11, "vertex index 9 out of range");
    }

    // ---- TetGen ---------------------------------------------------------------------------

    TEST(TetGen, OneBasedWithAttributesMarkersAndQuadraticTets)
    {
        const std::string node = "# points\n5 3 1 1\n"
                                 "1 0 0 0 0.5 1\n2 1 0 0 0.5 0\n3 0 1 0 0.5 0\n4 0 0 1 0.5 0\n"
                                 "5 1 1 1 0.5 1\n# Generated by tetgen\n";
        const std::string ele = "1 10 1\n1  1 2 3 4  5 5 5 5 5 5  7\n";
        const TetMesh mesh = read_tetgen_from_strings(node, "t.node", ele, "t.ele");
        ASSERT_EQ(mesh.num_vertices(), 5);
        EXPECT_EQ(mesh.positions(4, 1), 1.0);
        ASSERT_EQ(mesh.num_tets(), 1);
        EXPECT_TRUE(mesh.tets.row(0) == Eigen::RowVector4i(0, 1, 2, 3)) << mesh.tets;
    }

    TEST(TetGen, ShortHeadersAndOrientation)
    {
        const std::string node = "4\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
        const TetMesh mesh = read_tetgen_from_strings(node, "t.node", "1\n0 0 2 1 3\n", "t.ele");
        EXPECT_TRUE(mesh.tets.row(0) == Eigen::RowVector4i(0, 2, 3, 1)) << mesh.tets;
        EXPECT_GT(tet_orientation(mesh, 0), 0.0);
    }

    TEST(TetGen, RejectsBrokenNodeFile)
    {
        expect_node_error("", 1, "empty file");
        expect_node_error("4 3 0 0 9\n", 1, "malformed header: expected at most 4 values");
        expect_node_error("four 3\n", 1, "malformed header: 'four' is not a non-negative integer");
        expect_node_error("0 3 0 0\n", 1, "0 points");
        expect_node_error("4 2 0 0\n", 1, "dimension 2");
        expect_node_error("4 3 0 2\n", 1, "boundary-marker flag is 2");
        expect_node_error("4 3 0 0\n2 0 0 0\n", 2, "the first point id is 2: expected 0 or 1");
        expect_node_error(
            "4 3 0 0\n0 0 0 0\n2 1 0 0\n", 3, "point id 2 out of sequence: expected 1");
        expect_node_error("4 3 0 1\n0 0 0 0 1\n1 1 0 0\n", 3, "wrong number of fields: expected 5");
        expect_node_error("4 3 0 0\n0 0 0 0\n1 1 0 nan\n", 3, "z 'nan' is not finite");
        expect_node_error("4 3 0 0\n0 0 0 0\n1 1 0 1,5\n", 3, "z '1,5' is not a number");
        expect_node_error(
            "4 3 0 0\n0 0 0 0\n1 1 0 0\n", 4, "the header declares 4 points, found 2");
        expect_node_error("4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1\n", 6,
            "more data after the 4 points");
    }

    TEST(TetGen, RejectsBrokenEleFile)
    {
        expect_ele_error("", 1, "empty file");
        expect_ele_error("1 5 0\n", 1, "5 nodes per tet, expected 4 or 10");
        expect_ele_error("1 4 0\n0 0 1 2\n", 2, "wrong number of fields: expected 5");
        expect_ele_error("1 4 0\n0 0 1 2 4\n", 2, "node index 4 out of range: t.node has ids 0..3");
        expect_ele_error("1 4 0\n0 0 1 -1 3\n", 2, "node index -1 out of range");
        expect_ele_error("1 4 0\n0 0 1 1 3\n", 2, "degenerate tet: node index 1 is repeated");
        expect_ele_error("1 4 0\n0 0 1 x 3\n", 2, "node index 'x' is not an integer");
        expect_ele_error("1 4 1\n0 0 1 2 3 q\n", 2, "attribute 'q' is not a number");
        expect_ele_error("2 4 0\n0 0 1 2 3\n", 3, "the header declares 2 tets, found 1");
        expect_ele_error("1 4 0\n0 0 1 2 3\n1 0 1 2 3\n", 3, "more data after the 1 tets");
    }

    TEST_F(TetMeshIo, ReadTetGenNamesTheFiles)
    {
        write_text("m.node", "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n");
        write_text("m.ele", "1 4 0\n1 1 2 3 0\n");
        expect_line_error(
            [&] { read_tet_mesh(path("m.node")); }, path("m.ele"), 2, "node index 0 out of range");
        fs::remove(path("m.ele"));
        EXPECT_THROW(read_tetgen(path("m")), Error);
    }

    // ---- Writing: invalid meshes, atomicity -----------------------------------------------

    TEST_F(TetMeshIo, WriteRejectsInvalidMeshAndLeavesNoFile)
    {
        const TetMesh good = cube(2);
        auto expect_write_error = [&](const TetMesh& mesh, const std::string& what) {
            for (const char* name : { "bad.mesh", "bad.node" }) {
                try {
                    write_tet_mesh(path(name), mesh);
                    ADD_FAILURE() << "no error, expected " << what;
                } catch (const Error& e) {
                    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
                }
            }
            EXPECT_EQ(num_entries(), 0u);
        };
        TetMesh bad = good;
        bad.positions(3, 1) = std::numeric_limits<double>::infinity();
        expect_write_error(bad, "vertex 3 has a non-finite position");
        bad = good;
        bad.tets(4, 2) = 8;
        expect_write_error(bad, "tet 4 has vertex index 8 out of range");
        bad = good;
        bad.tets(1, 3) = bad.tets(1, 0);
        expect_write_error(bad, "tet 1 repeats vertex index");
        EXPECT_THROW(write_tet_mesh(path("empty.node"), TetMesh()), Error); // 0 points: see .poly
        EXPECT_EQ(num_entries(), 0u);
        // Medit can hold an empty mesh.
        write_tet_mesh(path("empty.mesh"), TetMesh());
        expect_equal(read_tet_mesh(path("empty.mesh")), TetMesh());
    }

    TEST_F(TetMeshIo, FailedTetGenWriteKeepsBothOldFiles)
    {
        write_text("m.node", "old node");
        // The .ele target is a directory: the write fails before anything is committed.
        fs::create_directories(path("m.ele"));
        EXPECT_THROW(write_tetgen(path("m"), cube(3)), Error);
        EXPECT_EQ(test::read_file_contents(path("m.node")), "old node");
        EXPECT_EQ(num_entries(), 2u);
    }

    // ---- Garbage never crashes ------------------------------------------------------------

    void check_accepted(const TetMesh& mesh)
    {
        ASSERT_TRUE(mesh.positions.allFinite());
        if (mesh.num_tets() > 0) {
            ASSERT_GE(mesh.tets.minCoeff(), 0);
            ASSERT_LT(mesh.tets.maxCoeff(), mesh.num_vertices());
        }
        for (Index t = 0; t < mesh.num_tets(); ++t)
            ASSERT_GE(tet_orientation(mesh, t), 0.0);
    }

    TEST(TetMeshIoFuzz, MutatedAndRandomInputsNeverCrash)
    {
        const std::string medit = medit_head
            + "Triangles 1\n1 2 3 0\nTetrahedra\n2\n"
              "1 2 3 4 0\n2 1 3 4 0\nEnd\n";
        const std::string node = "5 3 1 1\n1 0 0 0 0.5 1\n2 1 0 0 0.5 0\n3 0 1 0 0.5 0\n"
                                 "4 0 0 1 0.5 0\n5 1 1 1 0.5 1\n";
        const std::string ele = "2 4 0\n1 1 2 3 4\n2 2 3 4 5\n";
        const std::string alphabet = "0123456789 -+.eE#\n\tEndVertices";
        std::mt19937 rng(77);
        const auto level = logger().level();
        logger().set_level(spdlog::level::err); // accepted inputs log their reoriented tets
        int accepted = 0, rejected = 0;
        for (int iteration = 0; iteration < 3000; ++iteration) {
            const int kind = iteration % test::num_text_mutations;
            const int format = iteration % 3; // Medit, TetGen .node mutated, .ele mutated
            const std::string a = test::mutate_text(format == 0 ? medit
                    : format == 1                               ? node
                                                                : ele,
                rng, kind, alphabet);
            try {
                const TetMesh mesh = format == 0 ? read_medit_from_string(a, "f.mesh")
                    : format == 1 ? read_tetgen_from_strings(a, "f.node", ele, "f.ele")
                                  : read_tetgen_from_strings(node, "f.node", a, "f.ele");
                ++accepted;
                check_accepted(mesh);
            } catch (const Error& e) {
                ++rejected;
                const std::string message = e.what();
                EXPECT_EQ(message.rfind("f.", 0), 0u) << message;
                EXPECT_NE(message.find(": line "), std::string::npos) << message;
            } catch (...) {
                ADD_FAILURE() << "unexpected exception type";
            }
            if (HasFailure()) {
                ADD_FAILURE() << "stopped at iteration " << iteration << ":\n" << a;
                break;
            }
        }
        logger().set_level(level);
        EXPECT_GT(accepted, 30);
        EXPECT_GT(rejected, 1000);
    }

} // namespace
} // namespace mat
