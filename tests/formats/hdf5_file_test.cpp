#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <random>
#include <thread>

#include "common/eigen_types.hpp"
#include "common/error.hpp"
#include "formats/hdf5_file.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/random_data.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    namespace fs = std::filesystem;

    // Each test writes into its own directory (tests of this executable run in parallel).
    using Hdf5File = test::ScratchDirTest;

    using test::expect_error_containing;

    using test::random_positions;

    SparseRowMat random_sparse(Index rows, Index cols, double density, unsigned seed)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::vector<Eigen::Triplet<double>> triplets;
        for (Index r = 0; r < rows; ++r)
            for (Index c = 0; c < cols; ++c)
                if (u(rng) < density)
                    triplets.emplace_back(int(r), int(c), u(rng) - 0.5);
        SparseRowMat out(rows, cols);
        out.setFromTriplets(triplets.begin(), triplets.end());
        return out;
    }

    TEST_F(Hdf5File, DenseDoubleMatricesRoundTripInBothStorageOrders)
    {
        const MatX3 positions = random_positions(100, 1);
        Eigen::MatrixXd column_major(5, 4); // column-major: must keep its rows and cols
        column_major << 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20;
        RowMatX wide = RowMatX::Random(6, 5);
        {
            H5Writer writer(path("a.h5"));
            writer.write_matrix("mesh/rest_positions", positions);
            writer.write_matrix("column_major", column_major);
            // Blocks: rows not adjacent in memory (row-major) or a transposed copy (col-major).
            writer.write_matrix("row_block", wide.block(1, 1, 4, 3));
            writer.write_matrix("col_block", column_major.block(1, 1, 3, 2));
            writer.write_matrix("expression", positions.topRows(2) * 2.0);
            writer.commit();
        }
        const H5Reader reader(path("a.h5"));
        EXPECT_EQ(reader.shape("mesh/rest_positions"), (std::vector<Index> { 100, 3 }));
        EXPECT_EQ(reader.shape("/column_major"), (std::vector<Index> { 5, 4 }));
        EXPECT_EQ(reader.read<MatX3>("mesh/rest_positions"), positions);
        EXPECT_EQ(reader.read_matrix("mesh/rest_positions", 100, 3), positions);
        EXPECT_EQ(reader.read<Eigen::MatrixXd>("column_major"), column_major);
        const RowMatX column_read = reader.read_matrix("column_major");
        EXPECT_EQ(column_read(0, 1), 2.0); // row by row on disk, as printed
        EXPECT_EQ(column_read(4, 0), 17.0);
        EXPECT_EQ(reader.read_matrix("row_block", 4, 3), wide.block(1, 1, 4, 3));
        EXPECT_EQ(reader.read_matrix("col_block", 3, 2), RowMatX(column_major.block(1, 1, 3, 2)));
        EXPECT_EQ(reader.read_matrix("expression"), RowMatX(positions.topRows(2) * 2.0));
    }

    TEST_F(Hdf5File, IntegerMatricesAndVectorsRoundTrip)
    {
        MatX4i tets(3, 4);
        tets << 0, 1, 2, 3, 1, 2, 3, 4, -5, 6, 7, 2147483647;
        Eigen::MatrixXi column_major(2, 3);
        column_major << 1, 2, 3, 4, 5, 6;
        RowMatXl big(2, 2);
        big << 1, -(std::int64_t(1) << 40), std::int64_t(1) << 62, 7;
        const Eigen::VectorXd values = Eigen::VectorXd::LinSpaced(17, -1.0, 1.0);
        Eigen::VectorXi ids(4);
        ids << 4, 3, -2, 1;
        VecXl handles(3);
        handles << (std::int64_t(1) << 50), 0, -1;
        {
            H5Writer writer(path("i.h5"));
            writer.write_matrix("mesh/tets", tets);
            writer.write_matrix("column_major", column_major);
            writer.write_matrix("big", big);
            writer.write_vector("values", values);
            writer.write_vector("segment", values.segment(3, 5));
            writer.write_vector("ids", ids);
            writer.write_vector("handles", handles);
            writer.commit();
        }
        const H5Reader reader(path("i.h5"));
        EXPECT_EQ(reader.read<MatX4i>("mesh/tets"), tets);
        EXPECT_EQ(reader.read_matrix_int("column_major", 2, 3), RowMatXi(column_major));
        EXPECT_EQ(reader.read_matrix_int64("big"), big);
        EXPECT_EQ(reader.read_matrix_int64("mesh/tets"), tets.cast<std::int64_t>());
        EXPECT_EQ(reader.read_vector("values", 17), values);
        EXPECT_EQ(reader.read<Eigen::VectorXd>("segment"), values.segment(3, 5));
        EXPECT_EQ(reader.read_vector_int("ids"), ids);
        EXPECT_EQ(reader.read_vector_int64("handles", 3), handles);
        EXPECT_EQ(reader.read_vector_int64("ids"), ids.cast<std::int64_t>());
        EXPECT_EQ(reader.shape("values"), std::vector<Index> { 17 });
    }

    TEST_F(Hdf5File, SparseCsrRoundTripsWithScipyLayout)
    {
        const SparseRowMat a = random_sparse(50, 40, 0.1, 2);
        SparseRowMat uncompressed(4, 6);
        uncompressed.insert(2, 5) = 3.5;
        uncompressed.insert(0, 1) = -1.0;
        uncompressed.insert(2, 0) = 2.0;
        ASSERT_FALSE(uncompressed.isCompressed());
        {
            H5Writer writer(path("s.h5"));
            writer.write_sparse("pd/system", a);
            writer.write_sparse("uncompressed", uncompressed);
            writer.write_sparse("empty", SparseRowMat(3, 5));
            writer.write_sparse("nothing", SparseRowMat(0, 0));
            writer.commit();
        }
        const H5Reader reader(path("s.h5"));
        const SparseRowMat a_read = reader.read_sparse("pd/system", 50, 40);
        EXPECT_EQ(a_read.nonZeros(), a.nonZeros());
        EXPECT_EQ(RowMatX(a_read), RowMatX(a));
        EXPECT_EQ(RowMatX(reader.read_sparse("uncompressed")), RowMatX(uncompressed));
        EXPECT_EQ(reader.read_sparse("empty").rows(), 3);
        EXPECT_EQ(reader.read_sparse("empty").cols(), 5);
        EXPECT_EQ(reader.read_sparse("empty").nonZeros(), 0);
        EXPECT_EQ(reader.read_sparse("nothing").size(), 0);
        // The layout scipy.sparse.csr_matrix reads.
        EXPECT_EQ(
            reader.list("pd/system"), (std::vector<std::string> { "data", "indices", "indptr" }));
        EXPECT_EQ(reader.read_string_attribute("pd/system", "encoding"), "csr");
        const Eigen::VectorXi indptr = reader.read_vector_int("uncompressed/indptr", 5);
        EXPECT_EQ(indptr, (Eigen::VectorXi(5) << 0, 1, 1, 3, 3).finished());
        EXPECT_EQ(reader.read_vector_int("uncompressed/indices"), Eigen::Vector3i(1, 0, 5));
        expect_error_containing([&] { reader.read_sparse("pd/system", 50, 41); },
            { "s.h5", "'/pd/system'", "50 x 40", "50 x 41" });
        expect_error_containing([&] { reader.read_sparse("pd/system/data"); }, { "not a CSR" });
        expect_error_containing(
            [&] { reader.read_sparse("pd/missing"); }, { "no sparse matrix '/pd/missing'" });
    }

    TEST_F(Hdf5File, EmptyArraysKeepTheirShape)
    {
        {
            H5Writer writer(path("e.h5"));
            writer.write_matrix("no_rows", MatX3(0, 3));
            writer.write_matrix("nothing", Eigen::MatrixXd(0, 0));
            writer.write_matrix("no_tets", MatX4i(0, 4));
            writer.write_vector("empty", Eigen::VectorXd(0));
            writer.write_vector("empty_i", Eigen::VectorXi(0));
            writer.commit();
        }
        const H5Reader reader(path("e.h5"));
        EXPECT_EQ(reader.shape("no_rows"), (std::vector<Index> { 0, 3 }));
        EXPECT_EQ(reader.read<MatX3>("no_rows").rows(), 0);
        const RowMatX nothing = reader.read_matrix("nothing");
        EXPECT_EQ(nothing.rows(), 0);
        EXPECT_EQ(nothing.cols(), 0);
        EXPECT_EQ(reader.read<MatX4i>("no_tets", 0).rows(), 0);
        EXPECT_EQ(reader.read_vector("empty", 0).size(), 0);
        EXPECT_EQ(reader.read_vector_int("empty_i").size(), 0);
        expect_error_containing([&] { reader.read<MatX3>("no_tets"); }, { "0 x 4", "? x 3" });
    }

    TEST_F(Hdf5File, StringsAndScalarsRoundTripOnEveryKindOfObject)
    {
        const std::string unicode = "Größe — 形状 ✓ 🙂 \"quoted\"\ttab";
        std::string json = "{\"options\": [";
        for (int i = 0; i < 20000; ++i)
            json += std::to_string(i) + ",";
        json += "0]}"; // over 64 KiB: needs dense attribute storage
        ASSERT_GT(json.size(), 65536u);
        {
            H5Writer writer(path("t.h5"));
            writer.write_matrix("mesh/rest_positions", random_positions(4, 3));
            writer.set_attribute("/", "units", "m");
            writer.set_attribute("/", "name", unicode);
            writer.set_attribute("/", "empty", std::string());
            writer.set_attribute("/", "options", json);
            writer.set_attribute("mesh", "count", 4);
            writer.set_attribute("mesh", "big", std::int64_t(1) << 60);
            writer.set_attribute("mesh/rest_positions", "scale", 0.25);
            writer.set_attribute("mesh/rest_positions", "tiny", -1e-300);
            writer.set_attribute(
                "mesh/rest_positions", "inf", std::numeric_limits<double>::infinity());
            writer.set_attribute("mesh/rest_positions", "scale", 0.5); // replaces
            writer.write_string("log/text", unicode);
            writer.write_string("log/empty", "");
            writer.commit();
        }
        const H5Reader reader(path("t.h5"));
        EXPECT_EQ(reader.read_string_attribute("/", "units"), "m");
        EXPECT_EQ(reader.read_string_attribute("", "name"), unicode);
        EXPECT_EQ(reader.read_string_attribute("/", "empty"), "");
        EXPECT_EQ(reader.read_string_attribute("/", "options"), json);
        EXPECT_EQ(reader.read_int_attribute("/mesh", "count"), 4);
        EXPECT_EQ(reader.read_int_attribute("mesh/", "big"), std::int64_t(1) << 60);
        EXPECT_EQ(reader.read_double_attribute("mesh/rest_positions", "scale"), 0.5);
        EXPECT_EQ(reader.read_double_attribute("mesh/rest_positions", "tiny"), -1e-300);
        EXPECT_EQ(reader.read_double_attribute("mesh/rest_positions", "inf"),
            std::numeric_limits<double>::infinity());
        EXPECT_EQ(reader.read_string("log/text"), unicode);
        EXPECT_EQ(reader.read_string("log/empty"), "");
        EXPECT_EQ(reader.attribute_names("mesh/rest_positions"),
            (std::vector<std::string> { "inf", "scale", "tiny" }));
        EXPECT_TRUE(reader.has_attribute("/", "options"));
        EXPECT_FALSE(reader.has_attribute("/", "missing"));
        EXPECT_FALSE(reader.has_attribute("/nowhere", "units"));

        expect_error_containing([&] { reader.read_string_attribute("/", "missing"); },
            { "t.h5", "no attribute 'missing' on '/'" });
        expect_error_containing(
            [&] { reader.read_int_attribute("/nowhere", "x"); }, { "no object '/nowhere'" });
        expect_error_containing([&] { reader.read_double_attribute("mesh", "count"); },
            { "attribute 'count' of '/mesh'", "64-bit signed integers", "expected floating" });
        expect_error_containing(
            [&] { reader.read_int_attribute("/", "units"); }, { "text", "expected integers" });
        expect_error_containing(
            [&] { reader.read_string_attribute("mesh", "count"); }, { "expected text" });
        expect_error_containing(
            [&] { reader.read_string("mesh/rest_positions"); }, { "expected text" });
    }

    TEST_F(Hdf5File, GroupsListingAndLookup)
    {
        {
            H5Writer writer(path("g.h5"));
            writer.create_group("pd/reduced");
            writer.create_group("/pd/reduced/"); // already there: fine
            writer.write_vector("pd/reduced/weights", Eigen::VectorXd::Ones(3));
            writer.write_vector("basis/b", Eigen::VectorXd::Ones(2));
            writer.write_vector("mesh/z", Eigen::VectorXd::Ones(1));
            writer.write_vector("mesh/a", Eigen::VectorXd::Ones(1));
            expect_error_containing([&] { writer.create_group("mesh/a/below"); },
                { "g.h5", "group '/mesh/a/below'", "'/mesh/a' is a dataset, not a group" });
            expect_error_containing(
                [&] { writer.write_vector("mesh/a", Eigen::VectorXd::Ones(1)); },
                { "g.h5", "'/mesh/a'", "already exists" });
            expect_error_containing(
                [&] { writer.write_vector("a/../b", Eigen::VectorXd::Ones(1)); },
                { "invalid HDF5 path" });
            expect_error_containing(
                [&] { writer.set_attribute("missing", "x", 1); }, { "no object '/missing'" });
            writer.commit();
            expect_error_containing([&] { writer.write_vector("late", Eigen::VectorXd::Ones(1)); },
                { "already committed" });
        }
        const H5Reader reader(path("g.h5"));
        EXPECT_EQ(reader.list("/"), (std::vector<std::string> { "basis", "mesh", "pd" }));
        EXPECT_EQ(reader.list("mesh"), (std::vector<std::string> { "a", "z" }));
        EXPECT_EQ(reader.list("pd"), std::vector<std::string> { "reduced" });
        EXPECT_TRUE(reader.has("/"));
        EXPECT_TRUE(reader.has("pd/reduced"));
        EXPECT_TRUE(reader.has("/pd/reduced/weights"));
        EXPECT_FALSE(reader.has("pd/missing"));
        EXPECT_FALSE(reader.has("missing/deeper/still"));
        EXPECT_TRUE(reader.is_group("pd/reduced"));
        EXPECT_FALSE(reader.is_group("pd/reduced/weights"));
        EXPECT_TRUE(reader.is_dataset("pd/reduced/weights"));
        EXPECT_FALSE(reader.is_dataset("pd"));
        expect_error_containing([&] { reader.list("mesh/a"); }, { "'/mesh/a' is not a group" });
        expect_error_containing([&] { reader.list("nope"); }, { "no group '/nope'" });
    }

    TEST_F(Hdf5File, TruncatedFileIsAnErrorNotACrash)
    {
        {
            H5Writer writer(path("full.h5"));
            writer.stamp_format("medial-elastics-bake", 1);
            writer.write_matrix("mesh/rest_positions", random_positions(2000, 4));
            writer.write_sparse("pd/system", random_sparse(60, 60, 0.1, 5));
            writer.set_attribute("/", "options", std::string(1000, 'x'));
            writer.commit();
        }
        const std::string full = test::read_file_contents(path("full.h5"));
        for (const double fraction : { 0.01, 0.1, 0.3, 0.5, 0.9, 0.999 }) {
            const std::size_t size = std::size_t(double(full.size()) * fraction);
            const std::string cut = write_text("cut.h5", full.substr(0, size));
            try {
                const H5Reader reader(cut);
                reader.require_format("medial-elastics-bake", 1);
                reader.read<MatX3>("mesh/rest_positions");
                reader.read_sparse("pd/system");
                ADD_FAILURE() << "no error for a file cut to " << size << " of " << full.size();
            } catch (const Error& e) {
                EXPECT_NE(std::string(e.what()).find("cut.h5"), std::string::npos) << e.what();
            }
        }
    }

    TEST_F(Hdf5File, CompressedDatasetsRoundTrip)
    {
        MatX4i tets(50000, 4); // about 800 KB of small integers: compresses well
        for (Index i = 0; i < tets.rows(); ++i)
            tets.row(i) << int(i), int(i + 1), int(i + 2), int(i + 3);
        const MatX3 positions = random_positions(30000, 7);
        H5WriterOptions options;
        options.gzip_level = 4;
        for (const auto& [name, opts] :
            { std::pair { "plain.h5", H5WriterOptions {} }, std::pair { "gzip.h5", options } }) {
            H5Writer writer(path(name), opts);
            writer.write_matrix("tets", tets);
            writer.write_matrix("positions", positions);
            writer.write_vector("small", Eigen::VectorXd::Ones(3));
            writer.commit();
        }
        const H5Reader reader(path("gzip.h5"));
        EXPECT_EQ(reader.read<MatX4i>("tets"), tets);
        EXPECT_EQ(reader.read<MatX3>("positions"), positions);
        EXPECT_EQ(reader.read_vector("small"), Eigen::VectorXd::Ones(3));
        EXPECT_LT(fs::file_size(path("gzip.h5")) * 2, fs::file_size(path("plain.h5")));
        H5WriterOptions bad;
        bad.gzip_level = 10;
        expect_error_containing([&] { H5Writer(path("bad.h5"), bad); }, { "gzip level 10" });
    }

    // Writes the same content (also compressed) as a bake would.
    void write_sample(const std::string& path, const H5WriterOptions& options)
    {
        H5Writer writer(path, options);
        writer.stamp_format("medial-elastics-bake", 1);
        writer.set_attribute("/", "options", "{\"a\": 1}");
        writer.write_matrix("mesh/rest_positions", random_positions(5000, 11));
        writer.set_attribute("mesh/rest_positions", "units", "m");
        writer.write_matrix("mesh/tets", MatX4i::Constant(3000, 4, 7));
        writer.write_sparse("pd/system", random_sparse(40, 40, 0.2, 12));
        writer.create_group("collision");
        writer.write_string("log", "text");
        writer.commit();
    }

    TEST_F(Hdf5File, SameDataGivesByteIdenticalFiles)
    {
        H5WriterOptions gzip;
        gzip.gzip_level = 4;
        write_sample(path("a.h5"), {});
        write_sample(path("ga.h5"), gzip);
        // Timestamps have one-second resolution: write the second copies in a later second.
        std::this_thread::sleep_for(std::chrono::milliseconds(1100));
        write_sample(path("b.h5"), {});
        write_sample(path("gb.h5"), gzip);
        const std::string a = test::read_file_contents(path("a.h5"));
        ASSERT_GT(a.size(), 100000u);
        EXPECT_TRUE(a == test::read_file_contents(path("b.h5")));
        EXPECT_TRUE(
            test::read_file_contents(path("ga.h5")) == test::read_file_contents(path("gb.h5")));
    }

} // namespace
} // namespace mat
