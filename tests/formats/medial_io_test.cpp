#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <string>

#include "common/error.hpp"
#include "formats/medial_io.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"
#include "tests/support/text_mutation.hpp"

namespace mat {
namespace {

    // A fresh directory per test, removed afterwards.
    class MedialIo : public test::ScratchDirTest {
    protected:
        // Reads `text` from a file and expects mat::Error "<file>: line <line>: ...<what>...".
        void expect_error(const std::string& text, int line, const std::string& what) const
        {
            const std::string p = write_text("broken.ma", text);
            SCOPED_TRACE(text);
            test::expect_line_error([&] { read_medial(p); }, p, line, what);
        }
    };

    void expect_equal(const MedialMesh& a, const MedialMesh& b)
    {
        ASSERT_EQ(a.num_spheres(), b.num_spheres());
        ASSERT_EQ(a.num_cones(), b.num_cones());
        ASSERT_EQ(a.num_slabs(), b.num_slabs());
        EXPECT_TRUE(a.centers == b.centers); // bit for bit: %.17g round-trips every double
        EXPECT_TRUE(a.radii == b.radii);
        EXPECT_TRUE(a.cones == b.cones);
        EXPECT_TRUE(a.slabs == b.slabs);
    }

    // A random valid mesh whose cones lie on no slab edge.
    MedialMesh random_mesh(unsigned seed, int spheres)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> coord(-10.0, 10.0), radius(1e-3, 2.0);
        std::uniform_int_distribution<int> pick(0, spheres - 1);
        MedialMesh mesh;
        mesh.centers.resize(spheres, 3);
        mesh.radii.resize(spheres);
        for (int i = 0; i < spheres; ++i) {
            mesh.centers.row(i) = Vec3(coord(rng), coord(rng), coord(rng)).transpose();
            mesh.radii[i] = radius(rng);
        }
        std::set<std::set<int>> slabs, slab_edges, cones;
        std::vector<std::array<int, 3>> slab_list;
        while (slab_list.size() < static_cast<std::size_t>(spheres)) {
            const int a = pick(rng), b = pick(rng), c = pick(rng);
            if (a == b || b == c || a == c || !slabs.insert({ a, b, c }).second)
                continue;
            slab_list.push_back({ a, b, c });
            slab_edges.insert({ a, b });
            slab_edges.insert({ b, c });
            slab_edges.insert({ a, c });
        }
        std::vector<std::array<int, 2>> cone_list;
        for (int tries = 0; tries < 1000 && cone_list.size() < 10; ++tries) {
            const int a = pick(rng), b = pick(rng);
            if (a == b || slab_edges.count({ a, b }) || !cones.insert({ a, b }).second)
                continue;
            cone_list.push_back({ a, b });
        }
        mesh.slabs.resize(static_cast<Index>(slab_list.size()), 3);
        for (std::size_t s = 0; s < slab_list.size(); ++s)
            for (int k = 0; k < 3; ++k)
                mesh.slabs(static_cast<Index>(s), k) = slab_list[s][k];
        mesh.cones.resize(static_cast<Index>(cone_list.size()), 2);
        for (std::size_t c = 0; c < cone_list.size(); ++c)
            for (int k = 0; k < 2; ++k)
                mesh.cones(static_cast<Index>(c), k) = cone_list[c][k];
        return mesh;
    }

    // ---- Round trips ----------------------------------------------------------------------

    TEST_F(MedialIo, RoundTripBothDialects)
    {
        MedialMesh mesh = random_mesh(7, 30);
        ASSERT_GT(mesh.num_cones(), 0);
        // Values that need all 17 digits, extremes and a denormal.
        mesh.centers(0, 0) = 0.1 + 0.2;
        mesh.centers(1, 1) = -1e308;
        mesh.centers(2, 2) = 4.9e-324;
        mesh.radii[3] = 1.0 / 3.0;
        for (MedialDialect dialect : { MedialDialect::qmat, MedialDialect::paper }) {
            const std::string p = path(dialect == MedialDialect::qmat ? "q.ma" : "p.ma");
            write_medial(p, mesh, dialect);
            expect_equal(read_medial(p), mesh);
        }
        // Q-MAT lists every slab edge once besides the cones; the paper's lists only cones.
        std::set<std::set<int>> slab_edges;
        for (Index s = 0; s < mesh.num_slabs(); ++s)
            for (int k = 0; k < 3; ++k)
                slab_edges.insert({ mesh.slabs(s, k), mesh.slabs(s, (k + 1) % 3) });
        const std::string qmat = test::read_file_contents(path("q.ma"));
        EXPECT_EQ(qmat.substr(0, qmat.find('\n')),
            fmt::format("30 {} 30", mesh.num_cones() + slab_edges.size()));
        const std::string paper = test::read_file_contents(path("p.ma"));
        EXPECT_EQ(paper.substr(0, paper.find('\n')), fmt::format("30 {} 30", mesh.num_cones()));
        EXPECT_EQ(paper.find("\ne "), std::string::npos);
        EXPECT_NE(paper.find("\nc "), std::string::npos);
        EXPECT_NE(paper.find("\ns "), std::string::npos);
    }

    TEST_F(MedialIo, SpheresOnlyAndEmptyMeshes)
    {
        MedialMesh mesh;
        mesh.centers = MatX3::Zero(2, 3);
        mesh.radii = VecX::Constant(2, 0.5);
        for (MedialDialect dialect : { MedialDialect::qmat, MedialDialect::paper }) {
            write_medial(path("s.ma"), mesh, dialect);
            expect_equal(read_medial(path("s.ma")), mesh);
            write_medial(path("e.ma"), MedialMesh(), dialect);
            expect_equal(read_medial(path("e.ma")), MedialMesh());
        }
        EXPECT_EQ(test::read_file_contents(path("e.ma")), "0 0 0\n");
    }

    TEST_F(MedialIo, ConeOnSlabEdgeIsImpliedInQmatKeptInPaper)
    {
        MedialMesh mesh;
        mesh.centers = MatX3::Random(4, 3);
        mesh.radii = VecX::Constant(4, 0.1);
        mesh.slabs = (MatX3i(1, 3) << 0, 1, 2).finished();
        mesh.cones = (MatX2i(2, 2) << 1, 0, 2, 3).finished();
        write_medial(path("p.ma"), mesh, MedialDialect::paper);
        expect_equal(read_medial(path("p.ma")), mesh);
        write_medial(path("q.ma"), mesh, MedialDialect::qmat);
        const MedialMesh back = read_medial(path("q.ma"));
        EXPECT_TRUE(back.slabs == mesh.slabs);
        ASSERT_EQ(back.num_cones(), 1);
        EXPECT_EQ(back.cones(0, 0), 2);
        EXPECT_EQ(back.cones(0, 1), 3);
    }

    // ---- Q-MAT semantics and lenient syntax -----------------------------------------------

    TEST_F(MedialIo, QmatConesAreTheEdgesOnNoFace)
    {
        const std::string text = "# Q-MAT output\n"
                                 "5 6 1\n"
                                 "v 0 0 0 0.1\nv 1 0 0 0.2\nv 0 1 0 0.3\nv 0 0 1 0.4\nv 1 1 1 0.5\n"
                                 "e 1 0\n" // face edge, reversed
                                 "e 2 3\n" // cone
                                 "e 1 2\n" // face edge
                                 "e 3 4\n" // cone
                                 "e 0 2\n" // face edge
                                 "e 4 0\n" // cone
                                 "f 0 1 2\n";
        const MedialMesh mesh = read_medial(write_text("q.ma", text));
        ASSERT_EQ(mesh.num_spheres(), 5);
        EXPECT_DOUBLE_EQ(mesh.radii[4], 0.5);
        EXPECT_DOUBLE_EQ(mesh.centers(3, 2), 1.0);
        ASSERT_EQ(mesh.num_slabs(), 1);
        EXPECT_TRUE(mesh.slabs == (MatX3i(1, 3) << 0, 1, 2).finished());
        EXPECT_TRUE(mesh.cones == (MatX2i(3, 2) << 2, 3, 3, 4, 4, 0).finished()) << mesh.cones;
    }

    TEST_F(MedialIo, PaperDialectKeepsConesAsGiven)
    {
        const std::string text = "3 2 1\nv 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\n"
                                 "c 0 1\nc 2 1\ns 0 1 2\n";
        const MedialMesh mesh = read_medial(write_text("p.ma", text));
        EXPECT_TRUE(mesh.cones == (MatX2i(2, 2) << 0, 1, 2, 1).finished());
        EXPECT_TRUE(mesh.slabs == (MatX3i(1, 3) << 0, 1, 2).finished());
    }

    TEST_F(MedialIo, CommentsBlankLinesCrlfAndSpacing)
    {
        const std::string text
            = "\r\n# header next\r\n  2\t1 0   # counts\r\n\r\n"
              "v +1.5 -2e-3 3E2 .25\r\n# between\r\nv 1e-400 0 0 1e-9\r\ne 0 1\r\n";
        const MedialMesh mesh = read_medial(write_text("c.ma", text));
        ASSERT_EQ(mesh.num_spheres(), 2);
        EXPECT_EQ(mesh.centers(0, 0), 1.5);
        EXPECT_EQ(mesh.centers(0, 1), -2e-3);
        EXPECT_EQ(mesh.centers(0, 2), 300.0);
        EXPECT_EQ(mesh.radii[0], 0.25);
        EXPECT_EQ(mesh.radii[1], 1e-9);
        EXPECT_EQ(mesh.centers(1, 0), 0.0); // underflows to 0
        EXPECT_TRUE(mesh.cones == (MatX2i(1, 2) << 0, 1).finished());
    }

    // ---- Every validation class: its message and its line ---------------------------------

    const std::string three = "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\n";

    TEST_F(MedialIo, RejectsMissingHeader)
    {
        expect_error("", 1, "missing header");
        expect_error("# only a comment\n\n", 3, "missing header");
        expect_error("# c\nv 0 0 0 1\n", 2, "missing header");
    }

    TEST_F(MedialIo, RejectsMalformedHeader)
    {
        expect_error("3 0\n" + three, 1, "malformed header: expected 3 counts");
        expect_error("\n3 0 0 0\n" + three, 2, "malformed header: expected 3 counts");
        expect_error("3 x 0\n" + three, 1, "malformed header: count 'x'");
        expect_error("3 -1 0\n" + three, 1, "malformed header: count '-1'");
        expect_error("3 0 99999999999\n" + three, 1, "malformed header: count '99999999999'");
    }

    TEST_F(MedialIo, RejectsCountsThatDoNotMatchTheBody)
    {
        expect_error("# c\n4 0 0\n" + three, 2, "header expects 4 vertices, found 3");
        expect_error("2 0 0\n" + three, 1, "header expects 2 vertices, found 3");
        expect_error("3 2 0\n" + three + "e 0 1\n", 1, "header expects 2 edges, found 1");
        expect_error("3 1 2\n" + three + "e 0 1\nf 0 1 2\n", 1, "header expects 2 faces, found 1");
        expect_error("3 0 0\n" + three + "c 0 1\n", 1, "header expects 0 cones, found 1");
        expect_error("3 0 2\n" + three + "s 0 1 2\n", 1, "header expects 2 slabs, found 1");
        expect_error("3 1 0\n" + three, 1, "header expects 1 edges (cones), found 0");
    }

    TEST_F(MedialIo, RejectsUnknownRecord)
    {
        expect_error("3 0 0\n" + three + "x 1 2\n", 5, "unknown record 'x'");
        expect_error("3 0 0\nv 0 0 0 1\nvv 0 0 0 1\n", 3, "unknown record 'vv'");
        expect_error("3 0 0\n1 2 3 4\n", 2, "unknown record '1'");
    }

    TEST_F(MedialIo, RejectsWrongFieldCount)
    {
        expect_error("3 0 0\nv 0 0 0 1\nv 1 0 0\n", 3,
            "wrong number of fields: 'v' records have 4 values (v x y z r), found 3");
        expect_error("3 1 0\n" + three + "e 0 1 2\n", 5, "'e' records have 2 values");
        expect_error("3 0 1\n" + three + "s 0 1\n", 5, "'s' records have 3 values");
    }

    // Medial IPC's .mat: the cones/slabs dialect with the tet node of each sphere after its
    // radius (docs/mat-bake.md); the node is checked to be an integer and not kept.
    TEST_F(MedialIo, ReadsMedialIpcMatFilesIgnoringTheTetNode)
    {
        const std::string mat = "# Medial IPC\n4 2 1\n"
                                "v 0 0 0 0.5 12\nv 1 0 0 0.25 3\nv 0 1 0 0.5 0\nv 0 0 1 0.75 7\n"
                                "c 0 3\nc 1 3\ns 0 1 2\n";
        const MedialMesh mesh = read_medial(write_text("ipc.mat", mat));
        MedialMesh expected;
        expected.centers = MatX3::Zero(4, 3);
        expected.centers(1, 0) = expected.centers(2, 1) = expected.centers(3, 2) = 1.0;
        expected.radii = (VecX(4) << 0.5, 0.25, 0.5, 0.75).finished();
        expected.cones = (MatX2i(2, 2) << 0, 3, 1, 3).finished();
        expected.slabs = (MatX3i(1, 3) << 0, 1, 2).finished();
        expect_equal(mesh, expected);
        // The same mesh without the tet nodes reads the same.
        std::string ma = mat;
        for (const char* node : { " 12\n", " 3\n", " 0\n", " 7\n" })
            ma.replace(ma.find(node), std::string(node).size(), "\n");
        expect_equal(mesh, read_medial(write_text("ipc.ma", ma)));

        expect_error("2 0 0\nv 0 0 0 1 4\nv 1 0 0 1 4.5\n", 3,
            "tet node '4.5' of vertex 1 is not an integer");
        expect_error("2 0 0\nv 0 0 0 1 4\nv 1 0 0 1\n", 3,
            "'v' records have 5 values (v x y z r tet-node) since line 2, found 4");
        expect_error("2 0 0\nv 0 0 0 1\nv 1 0 0 1 4\n", 3, "'v' records have 4 values");
        expect_error("3 1 0\nv 0 0 0 1 0\nv 1 0 0 1 1\nv 0 1 0 1 2\ne 0 1\n", 5,
            "'e' record (Q-MAT dialect) in a .mat file (5-value 'v' records from line 2)");
    }

    TEST_F(MedialIo, RejectsNonNumericAndNonFiniteValues)
    {
        expect_error(
            "2 0 0\nv 0 0 0 1\nv 1 abc 0 1\n", 3, "value 'abc' of field 'y' is not a number");
        expect_error("2 0 0\nv 0 0 0 1\nv 1 1.5x 0 1\n", 3, "'1.5x' of field 'y' is not a number");
        expect_error(
            "2 0 0\nv 0 0 nan 1\nv 1 0 0 1\n", 2, "value 'nan' of field 'z' is not finite");
        expect_error("2 0 0\nv inf 0 0 1\n", 2, "value 'inf' of field 'x' is not finite");
        expect_error("2 0 0\nv 1e999 0 0 1\n", 2, "'1e999' of field 'x' is not finite");
        expect_error("3 1 0\n" + three + "e 0 1.0\n", 5, "index '1.0' is not an integer");
    }

    TEST_F(MedialIo, RejectsIndexOutOfRange)
    {
        expect_error("3 1 0\n" + three + "e 0 3\n", 5, "index 3 out of range");
        expect_error("3 1 0\n" + three + "c -1 0\n", 5, "index -1 out of range");
        expect_error("3 0 1\n" + three + "\nf 0 1 7\n", 6, "index 7 out of range");
    }

    TEST_F(MedialIo, RejectsBadRadius)
    {
        expect_error("2 0 0\nv 0 0 0 1\nv 0 0 0 0\n", 3, "radius 0 of vertex 1 must be > 0");
        expect_error("1 0 0\nv 0 0 0 -2.5\n", 2, "radius -2.5 of vertex 0 must be > 0");
        expect_error("1 0 0\nv 0 0 0 inf\n", 2, "field 'r' is not finite");
    }

    TEST_F(MedialIo, RejectsDegeneratePrimitives)
    {
        expect_error("3 1 0\n" + three + "e 1 1\n", 5, "degenerate edge 1 1");
        expect_error("3 3 1\n" + three + "e 0 1\ne 1 2\ne 0 2\nf 0 1 0\n", 8,
            "degenerate face 0 1 0: vertex index 0 is repeated");
        expect_error("3 1 0\n" + three + "c 2 2\n", 5, "degenerate cone 2 2");
        expect_error("3 0 1\n" + three + "s 1 2 2\n", 5, "degenerate slab 1 2 2");
    }

    TEST_F(MedialIo, RejectsDuplicatePrimitives)
    {
        expect_error("3 3 0\n" + three + "e 0 1\ne 1 2\ne 1 0\n", 7,
            "duplicate edge 1 0: same vertices as line 5");
        expect_error("3 3 2\n" + three + "e 0 1\ne 1 2\ne 0 2\nf 0 1 2\n# again\nf 2 0 1\n", 10,
            "duplicate face 2 0 1: same vertices as line 8");
        expect_error("3 2 0\n" + three + "c 0 2\nc 2 0\n", 6, "duplicate cone 2 0");
        expect_error("3 0 2\n" + three + "s 0 1 2\ns 1 0 2\n", 6,
            "duplicate slab 1 0 2: same vertices as line 5");
    }

    TEST_F(MedialIo, RejectsMixedDialects)
    {
        expect_error("3 1 1\n" + three + "e 0 1\ns 0 1 2\n", 6,
            "'s' record (paper dialect) after the 'e' record of line 5 (Q-MAT dialect)");
        expect_error("3 1 1\n" + three + "c 0 1\nf 0 1 2\n", 6,
            "'f' record (Q-MAT dialect) after the 'c' record of line 5 (paper dialect)");
    }

    TEST_F(MedialIo, MissingFileAndDirectory)
    {
        EXPECT_THROW(read_medial(path("absent.ma")), Error);
        EXPECT_THROW(read_medial(dir().string()), Error);
    }

    // ---- Writing: invalid meshes and atomicity --------------------------------------------

    TEST_F(MedialIo, WriteRejectsInvalidMeshAndLeavesTargetUntouched)
    {
        const std::string p = write_text("keep.ma", "previous content");
        const MedialMesh good = random_mesh(3, 6);
        auto expect_write_error = [&](const MedialMesh& mesh, const std::string& what) {
            for (MedialDialect dialect : { MedialDialect::qmat, MedialDialect::paper }) {
                try {
                    write_medial(p, mesh, dialect);
                    ADD_FAILURE() << "no error, expected " << what;
                } catch (const Error& e) {
                    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
                    EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << e.what();
                }
                EXPECT_EQ(test::read_file_contents(p), "previous content");
            }
        };
        MedialMesh bad = good;
        bad.radii[2] = 0.0;
        expect_write_error(bad, "sphere 2 has radius 0");
        bad = good;
        bad.centers(1, 1) = std::nan("");
        expect_write_error(bad, "sphere 1 has a non-finite center");
        bad = good;
        bad.slabs(0, 2) = 6;
        expect_write_error(bad, "slab 0 has sphere index 6 out of range");
        bad = good;
        bad.cones = (MatX2i(2, 2) << 0, 1, 1, 0).finished();
        expect_write_error(bad, "cone 1 (1 0) is a duplicate");
        bad = good;
        bad.cones = (MatX2i(1, 2) << 4, 4).finished();
        expect_write_error(bad, "cone 0 is degenerate");
        bad = good;
        bad.radii.resize(5);
        expect_write_error(bad, "6 sphere centers but 5 radii");

        EXPECT_THROW(write_medial(path("no/such/dir/x.ma"), good), Error);
        // Only the untouched file is left: no temporaries.
        EXPECT_EQ(num_entries(), 1u);
    }

    // ---- Garbage never crashes ------------------------------------------------------------

    // Every mesh the reader accepts is valid, and writes and reads back the same.
    void check_accepted(const MedialMesh& mesh)
    {
        ASSERT_EQ(mesh.radii.size(), mesh.num_spheres());
        for (Index i = 0; i < mesh.num_spheres(); ++i) {
            ASSERT_TRUE(mesh.centers.row(i).allFinite());
            ASSERT_GT(mesh.radii[i], 0.0);
        }
        ASSERT_TRUE(mesh.cones.size() == 0
            || (mesh.cones.minCoeff() >= 0 && mesh.cones.maxCoeff() < mesh.num_spheres()));
        ASSERT_TRUE(mesh.slabs.size() == 0
            || (mesh.slabs.minCoeff() >= 0 && mesh.slabs.maxCoeff() < mesh.num_spheres()));
        expect_equal(
            read_medial_from_string(format_medial(mesh, MedialDialect::paper), "again"), mesh);
    }

    TEST(MedialIoFuzz, MutatedAndRandomInputsNeverCrash)
    {
        const std::vector<std::string> seeds {
            "4 6 1\nv 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nv 0 0 1 2\n"
            "e 0 1\ne 1 2\ne 0 2\ne 2 3\ne 1 3\ne 0 3\nf 0 1 2\n",
            "# paper\n4 2 2\nv 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nv 0 0 1 2\n"
            "c 0 3\nc 1 3\ns 0 1 2\ns 1 2 3\n",
            format_medial(random_mesh(11, 8), MedialDialect::qmat),
            format_medial(random_mesh(12, 8), MedialDialect::paper),
        };
        const std::string alphabet = "0123456789 -+.eEvfcsx#\n\t\r";
        std::mt19937 rng(2024);
        std::uniform_int_distribution<std::size_t> pick_seed(0, seeds.size() - 1);
        int accepted = 0, rejected = 0;
        for (int iteration = 0; iteration < 4000; ++iteration) {
            const std::string text = test::mutate_text(
                seeds[pick_seed(rng)], rng, iteration % test::num_text_mutations, alphabet);
            try {
                const MedialMesh mesh = read_medial_from_string(text, "fuzz.ma");
                ++accepted;
                check_accepted(mesh);
            } catch (const Error& e) {
                ++rejected;
                const std::string message = e.what();
                EXPECT_EQ(message.rfind("fuzz.ma: line ", 0), 0u) << message;
                EXPECT_EQ(message.find('\n'), std::string::npos);
            } catch (...) {
                ADD_FAILURE() << "unexpected exception type for input:\n" << text;
            }
            if (HasFailure())
                FAIL() << "stopped at iteration " << iteration << ", input:\n" << text;
        }
        // Both outcomes must occur, or the mutations test nothing.
        EXPECT_GT(accepted, 100);
        EXPECT_GT(rejected, 1000);
    }

} // namespace
} // namespace mat
