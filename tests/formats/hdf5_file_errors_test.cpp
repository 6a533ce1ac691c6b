// HDF5 files: damaged, mistyped, unstamped or missing data and abandoned writers give one clear
// mat::Error and never leave a partial file.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/error.hpp"
#include "formats/hdf5_file.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/temp_files.hpp"

namespace mat {
namespace {

    namespace fs = std::filesystem;

    using test::expect_error_containing;

    // Each test writes into its own directory (tests of this executable run in parallel).
    using Hdf5FileErrors = test::ScratchDirTest;

    // A CSR matrix with the given raw arrays, unchecked (written straight into Eigen's arrays).
    SparseRowMat raw_csr(
        Index rows, Index cols, const std::vector<int>& indptr, const std::vector<int>& indices)
    {
        SparseRowMat out(rows, cols);
        out.resizeNonZeros(Index(indices.size()));
        std::copy(indptr.begin(), indptr.end(), out.outerIndexPtr());
        std::copy(indices.begin(), indices.end(), out.innerIndexPtr());
        std::fill_n(out.valuePtr(), indices.size(), 1.0);
        return out;
    }

    TEST_F(Hdf5FileErrors, DamagedSparseMatrixIsAnError)
    {
        {
            H5Writer writer(path("bad.h5"));
            writer.write_sparse("unsorted", raw_csr(2, 5, { 0, 2, 2 }, { 3, 1 }));
            writer.write_sparse("out_of_range", raw_csr(2, 5, { 0, 1, 2 }, { 0, 9 }));
            writer.write_sparse("negative", raw_csr(2, 5, { 0, 1, 2 }, { 0, -1 }));
            writer.write_sparse("good", raw_csr(2, 5, { 0, 1, 2 }, { 0, 4 }));
            writer.create_group("no_shape");
            writer.set_attribute("no_shape", "encoding", "csr");
            writer.create_group("other");
            writer.set_attribute("other", "encoding", "coo");
            writer.commit();
        }
        const H5Reader reader(path("bad.h5"));
        EXPECT_EQ(reader.read_sparse("good", 2, 5).coeff(1, 4), 1.0);
        expect_error_containing([&] { reader.read_sparse("unsorted"); },
            { "bad.h5", "'/unsorted'", "columns of row 0 are not increasing at entry 1" });
        expect_error_containing([&] { reader.read_sparse("out_of_range"); },
            { "'/out_of_range'", "column 9 of entry 1 (row 1) is out of range 0..4" });
        expect_error_containing(
            [&] { reader.read_sparse("negative"); }, { "column -1 of entry 1" });
        expect_error_containing([&] { reader.read_sparse("no_shape"); },
            { "bad.h5", "no attribute 'shape' on '/no_shape'" });
        expect_error_containing(
            [&] { reader.read_sparse("other"); }, { "'/other' is not a CSR sparse matrix" });
    }

    TEST_F(Hdf5FileErrors, DatasetStoringLessThanItsShapeIsAnError)
    {
        // Found by fuzzing: a trajectory whose '/time' layout was damaged into chunks that were
        // never stored; HDF5 1.10 read past its own buffer (seen under AddressSanitizer).
        const std::string path = std::string(MAT_TEST_DATA_DIR)
            + "/../fuzz/regressions/fuzz_trajectory_raw/"
              "crash-hdf5-overread-unstored-chunks-1cdecffe";
        const H5Reader reader(path);
        expect_error_containing([&] { reader.read_vector("time"); },
            { path,
                "dataset '/time' has shape 4 (32 bytes) but stores 0 bytes: the file is "
                "damaged" });
    }

    TEST_F(Hdf5FileErrors, WrongShapeRankOrTypeIsAnErrorNamingFileAndDataset)
    {
        MatX4i four(7, 4);
        four.setZero();
        {
            H5Writer writer(path("m.h5"));
            writer.write_matrix("mesh/rest_positions", RowMatX::Zero(10, 4));
            writer.write_matrix("mesh/tets", four);
            writer.write_vector("weights", Eigen::VectorXd::Zero(5));
            writer.write_vector("huge", (VecXl(2) << 1, std::int64_t(1) << 40).finished());
            writer.write_string("text", "hello");
            writer.commit();
        }
        const H5Reader reader(path("m.h5"));
        expect_error_containing([&] { reader.read<MatX3>("mesh/rest_positions"); },
            { "m.h5", "'/mesh/rest_positions'", "shape 10 x 4", "expected ? x 3" });
        expect_error_containing([&] { reader.read_matrix("mesh/rest_positions", 11, 4); },
            { "shape 10 x 4", "expected 11 x 4" });
        expect_error_containing([&] { reader.read_matrix("weights"); },
            { "'/weights'", "shape 5", "expected a 2-D dataset" });
        expect_error_containing([&] { reader.read_vector("mesh/rest_positions"); },
            { "shape 10 x 4", "expected a 1-D dataset" });
        expect_error_containing(
            [&] { reader.read_vector("weights", 6); }, { "shape 5", "expected 6" });
        expect_error_containing([&] { reader.read_matrix_int("mesh/rest_positions"); },
            { "'/mesh/rest_positions'", "64-bit floats", "expected integers" });
        expect_error_containing(
            [&] { reader.read<Eigen::Matrix<double, Eigen::Dynamic, 4>>("mesh/tets"); },
            { "'/mesh/tets'", "32-bit signed integers", "expected floating" });
        expect_error_containing([&] { reader.read_matrix("text"); }, { "'/text'" });
        expect_error_containing([&] { reader.read_vector_int("huge"); },
            { "'/huge'", "value 1099511627776 at entry 1", "32-bit" });
        expect_error_containing([&] { reader.read_vector("missing/weights"); },
            { "m.h5", "no dataset '/missing/weights'" });
        expect_error_containing(
            [&] { reader.read_matrix("mesh"); }, { "'/mesh' is a group, expected a dataset" });
        expect_error_containing([&] { reader.shape("nope"); }, { "no dataset '/nope'" });
    }

    TEST_F(Hdf5FileErrors, AbandonedWriterLeavesNoFileAndKeepsAnExistingTarget)
    {
        const std::string target = path("out.h5");
        {
            H5Writer writer(target);
            writer.write_vector("v", Eigen::VectorXd::Ones(10));
        } // no commit
        EXPECT_FALSE(fs::exists(target));
        EXPECT_EQ(num_entries(), 0u) << "temporary file left behind";

        {
            H5Writer writer(target);
            writer.write_vector("v", Eigen::VectorXd::Ones(10));
            writer.commit();
        }
        const std::string before = test::read_file_contents(target);
        ASSERT_FALSE(before.empty());
        {
            H5Writer writer(target);
            writer.write_vector("v", Eigen::VectorXd::Zero(1000));
        }
        try { // a failure half-way through a write
            H5Writer writer(target);
            writer.write_vector("w", Eigen::VectorXd::Zero(1000));
            writer.write_vector("w", Eigen::VectorXd::Zero(1000));
            writer.commit();
            FAIL() << "no error";
        } catch (const Error&) {
        }
        EXPECT_EQ(test::read_file_contents(target), before);
        EXPECT_EQ(num_entries(), 1u);
        EXPECT_EQ(H5Reader(target).read_vector("v"), Eigen::VectorXd::Ones(10));

        // A moved writer keeps writing the same file.
        H5Writer first(path("moved.h5"));
        first.write_vector("a", Eigen::VectorXd::Ones(2));
        H5Writer second(std::move(first));
        second.write_vector("b", Eigen::VectorXd::Ones(2));
        second.commit();
        EXPECT_EQ(H5Reader(path("moved.h5")).list("/"), (std::vector<std::string> { "a", "b" }));
        expect_error_containing([&] { H5Writer(path("no_such_dir/x.h5")); }, { "does not exist" });
    }

    TEST_F(Hdf5FileErrors, FormatStampIsChecked)
    {
        {
            H5Writer writer(path("v2.h5"));
            writer.stamp_format("medial-elastics-bake", 2);
            writer.commit();
        }
        {
            H5Writer writer(path("v3.h5"));
            writer.stamp_format("medial-elastics-bake", 3);
            writer.commit();
        }
        {
            H5Writer writer(path("other.h5"));
            writer.stamp_format("something-else", 1);
            writer.commit();
        }
        {
            H5Writer writer(path("plain.h5"));
            writer.write_vector("v", Eigen::VectorXd::Ones(1));
            writer.commit();
        }
        EXPECT_EQ(H5Reader(path("v2.h5")).require_format("medial-elastics-bake", 2), 2);
        EXPECT_EQ(H5Reader(path("v2.h5")).require_format("medial-elastics-bake", 5), 2);
        expect_error_containing(
            [&] { H5Reader(path("v3.h5")).require_format("medial-elastics-bake", 2, "mat-run"); },
            { "v3.h5: medial-elastics-bake format version 3 is newer than mat-run supports (2)" });
        expect_error_containing(
            [&] { H5Reader(path("other.h5")).require_format("medial-elastics-bake", 2); },
            { "other.h5", "'something-else'", "expected a 'medial-elastics-bake' file" });
        expect_error_containing(
            [&] { H5Reader(path("plain.h5")).require_format("medial-elastics-bake", 2); },
            { "plain.h5: not a medial-elastics-bake file" });
        H5Writer writer(path("x.h5"));
        EXPECT_THROW(writer.stamp_format("medial-elastics-bake", 0), Error);
    }

    TEST_F(Hdf5FileErrors, NonHdf5OrMissingFileIsAClearError)
    {
        write_text("text.h5", "this is not HDF5\n");
        write_text("empty.h5", "");
        expect_error_containing(
            [&] { H5Reader(path("text.h5")); }, { "text.h5: not an HDF5 file" });
        expect_error_containing(
            [&] { H5Reader(path("empty.h5")); }, { "empty.h5: not an HDF5 file" });
        expect_error_containing(
            [&] { H5Reader(path("missing.h5")); }, { "missing.h5: cannot open: no such file" });
        expect_error_containing([&] { H5Reader(dir().string()); }, { "is a directory" });
    }

} // namespace
} // namespace mat
