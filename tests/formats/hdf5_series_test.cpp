#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/error.hpp"
#include "formats/hdf5_file.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    using Hdf5Series = test::ScratchDirTest;
    using test::expect_error_containing;

    RowMatX random_matrix(Index rows, Index cols, unsigned seed)
    {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        RowMatX out(rows, cols);
        for (Index i = 0; i < out.size(); ++i)
            out.data()[i] = u(rng);
        return out;
    }

    // Writes scalar, vector and matrix series of `items` items (item i from seed i).
    void write_series(const std::string& file, int items, H5WriterOptions options = {})
    {
        H5Writer writer(file, options);
        writer.create_series("time", {});
        writer.create_series("rows/energy", { 4 });
        writer.create_series("objects/a/positions", { 5, 3 });
        EXPECT_EQ(writer.series_size("time"), 0);
        for (int i = 0; i < items; ++i) {
            writer.append("time", 0.5 * i);
            writer.append("/rows/energy", random_matrix(1, 4, unsigned(i)));
            writer.append("objects/a/positions", random_matrix(5, 3, unsigned(1000 + i)));
        }
        EXPECT_EQ(writer.series_size("objects/a/positions"), items);
        writer.commit();
    }

    TEST_F(Hdf5Series, ScalarVectorAndMatrixItemsRoundTrip)
    {
        write_series(path("s.h5"), 70); // more than one chunk of 64 items
        const H5Reader reader(path("s.h5"));
        EXPECT_EQ(reader.shape("time"), (std::vector<Index> { 70 }));
        EXPECT_EQ(reader.shape("rows/energy"), (std::vector<Index> { 70, 4 }));
        EXPECT_EQ(reader.shape("objects/a/positions"), (std::vector<Index> { 70, 5, 3 }));
        const Eigen::VectorXd time = reader.read_vector("time", 70);
        const RowMatX energy = reader.read_matrix("rows/energy", 70, 4);
        for (int i : { 0, 1, 63, 64, 69 }) {
            EXPECT_EQ(time[i], 0.5 * i);
            EXPECT_EQ(reader.read_series_item("time", i, 1, 1)(0, 0), 0.5 * i);
            EXPECT_EQ(RowMatX(energy.row(i)), random_matrix(1, 4, unsigned(i)));
            EXPECT_EQ(reader.read_series_item("rows/energy", i), random_matrix(1, 4, unsigned(i)));
            EXPECT_EQ(reader.read_series_item("objects/a/positions", i, 5, 3),
                random_matrix(5, 3, unsigned(1000 + i)));
        }
        expect_error_containing([&] { reader.read_series_item("time", 70); },
            { path("s.h5"), "'/time'", "70 items", "item 70" });
        expect_error_containing([&] { reader.read_series_item("objects/a/positions", 0, 4, 3); },
            { path("s.h5"), "'/objects/a/positions'", "70 x 5 x 3" });
    }

    TEST_F(Hdf5Series, SameWritesGiveTheSameBytesWithAndWithoutGzip)
    {
        write_series(path("a.h5"), 10);
        write_series(path("b.h5"), 10);
        EXPECT_EQ(test::read_file_contents(path("a.h5")), test::read_file_contents(path("b.h5")));
        H5WriterOptions gzip;
        gzip.gzip_level = 1;
        write_series(path("c.h5"), 10, gzip);
        write_series(path("d.h5"), 10, gzip);
        EXPECT_EQ(test::read_file_contents(path("c.h5")), test::read_file_contents(path("d.h5")));
        EXPECT_EQ(H5Reader(path("c.h5")).read_series_item("objects/a/positions", 9),
            random_matrix(5, 3, 1009));
    }

    TEST_F(Hdf5Series, ItemsLargerThanAChunkAreSplitByRows)
    {
        const RowMatX big0 = random_matrix(50000, 3, 1); // 1.2 MB per item
        const RowMatX big1 = random_matrix(50000, 3, 2);
        {
            H5Writer writer(path("big.h5"));
            writer.create_series("positions", { 50000, 3 });
            writer.append("positions", big0);
            writer.append("positions", big1);
            writer.commit();
        }
        const H5Reader reader(path("big.h5"));
        EXPECT_EQ(reader.read_series_item("positions", 1), big1);
        EXPECT_EQ(reader.read_series_item("positions", 0), big0);
    }

    TEST_F(Hdf5Series, BadCallsThrowAndKeepTheSeries)
    {
        const std::string file = path("s.h5");
        H5Writer writer(file);
        writer.create_series("x", { 2, 3 });
        writer.append("x", RowMatX::Ones(2, 3));
        expect_error_containing([&] { writer.append("x", RowMatX::Ones(3, 2)); },
            { file, "'/x'", "3 x 2", "expected 2 x 3" });
        expect_error_containing([&] { writer.append("x", 1.0); }, { file, "'/x'" });
        expect_error_containing([&] { writer.append("y", 1.0); }, { file, "'/y'", "not a series" });
        expect_error_containing([&] { writer.create_series("x", {}); }, { file, "already exists" });
        expect_error_containing(
            [&] { writer.create_series("z", { 0 }); }, { file, "'/z'", "dimension 0" });
        expect_error_containing(
            [&] {
                writer.create_series("z", { 1, 2, 3 });
            },
            { file, "'/z'", "rank 3" });
        writer.write_matrix("plain", RowMatX::Ones(2, 2));
        expect_error_containing(
            [&] { writer.append("plain", RowMatX::Ones(2, 2)); }, { file, "not a series" });
        EXPECT_EQ(writer.series_size("x"), 1);
        // A block whose rows are not adjacent in memory.
        const RowMatX wide = random_matrix(4, 5, 3);
        writer.append("x", wide.block(1, 1, 2, 3));
        writer.commit();
        const H5Reader reader(file);
        EXPECT_EQ(reader.shape("x"), (std::vector<Index> { 2, 2, 3 }));
        EXPECT_EQ(reader.read_series_item("x", 1), RowMatX(wide.block(1, 1, 2, 3)));
        expect_error_containing(
            [&] { reader.read_series_item("plain", 0, 1, 3); }, { file, "'/plain'" });
    }

} // namespace
} // namespace mat
