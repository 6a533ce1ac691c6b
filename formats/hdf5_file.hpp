#pragma once
// HDF5 files for the bake: one file holds everything the runtime needs, in groups (/mesh,
// /weights, /basis, /pd, ...) of datasets (dense matrices, vectors, CSR sparse matrices, text)
// and attributes (strings, integers, doubles) on the file, a group or a dataset.
//
// This header includes no HDF5 header: the HDF5 handles live in the .cpp (pimpl).
//
// Layout on disk:
// - a dense matrix is a 2-D dataset with the matrix's rows and cols, stored row by row (HDF5's
//   C order), whatever the storage order of the Eigen input: a row-major #V x 3 array is
//   written as is, a column-major one is transposed in memory first. h5dump and h5py show it as
//   the same #V x 3 table.
// - a vector is a 1-D dataset; text is a scalar fixed-length UTF-8 string dataset.
// - a sparse matrix is a group with the datasets `indptr` (#rows+1, int32), `indices` (nnz,
//   int32) and `data` (nnz, double) and the attributes `encoding` = "csr" and `shape` =
//   [rows, cols] (int64): the layout scipy.sparse.csr_matrix((data, indices, indptr), shape)
//   reads.
// - doubles are IEEE little-endian 64-bit, ints little-endian 32-bit, int64 little-endian 64-bit.
// - objects carry no timestamps, so writing the same data twice gives byte-identical files.
//
// Paths: "mesh/rest_positions" and "/mesh/rest_positions" are the same object; "/" (or "") is
// the root. Writing a dataset creates its missing parent groups.
//
// Errors: every failure (missing object, wrong rank/type/shape, not an HDF5 file, truncated
// file, I/O error) throws mat::Error naming the file and the object path. HDF5's own error
// printing to stderr is switched off for the whole process the first time a reader or writer
// is made.
//
// Thread safety: none. Debian's HDF5 is built without its thread-safe option, so at most one
// thread at a time may call into any H5Writer or H5Reader (or HDF5 at all).

#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "common/eigen_types.hpp"

namespace mat {

/// Dense matrices as the HDF5 helpers take and return them: row-major, like the file.
using RowMatX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatXi = Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatXl = Eigen::Matrix<std::int64_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using VecXl = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>;
/// A CSR sparse matrix.
using SparseRowMat = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// How an H5Writer stores its datasets.
struct H5WriterOptions {
    /// gzip level 1..9 for datasets of at least `compress_min_bytes` (with the shuffle filter,
    /// in chunks of about 1 MiB); 0 stores every dataset uncompressed and contiguous.
    /// If the HDF5 library lacks the deflate filter, datasets are stored uncompressed.
    /// Off by default: on a bake-like file (100k vertices, 500k tets, dense weights, a CSR
    /// system, a basis; 99 MB) level 1 saved 35% (index arrays 3x, random doubles ~12%) but
    /// made writing ~20x and reading ~7x slower (0.17 s -> 1.1 s); higher levels gained ~2%.
    int gzip_level = 0;
    /// Datasets smaller than this stay uncompressed and contiguous.
    std::int64_t compress_min_bytes = 64 * 1024;
    /// HDF5's file lock while writing; off lets other processes read a published file as it
    /// is written (H5Writer::publish).
    bool file_locking = true;
};

/// Writes one HDF5 file atomically: everything goes to a temporary file beside the target, and
/// commit() closes it and renames it over the target. A writer destroyed without commit()
/// (an exception, an early return) leaves no file at the target and an existing target as it
/// was, unless it was published (publish(): a file written in place, which stays). Objects are
/// written once: writing a dataset or group path that already exists as a dataset throws; setting
/// an attribute that exists replaces it.
class H5Writer {
public:
    /// Starts writing `target`. Throws mat::Error if its directory does not exist or the
    /// temporary file cannot be created.
    explicit H5Writer(std::string target, H5WriterOptions options = {});
    /// Without commit(): closes and removes the temporary file; the target is untouched.
    ~H5Writer();
    H5Writer(const H5Writer&) = delete;
    H5Writer& operator=(const H5Writer&) = delete;
    H5Writer(H5Writer&&) noexcept;
    H5Writer& operator=(H5Writer&&) noexcept;

    const std::string& target() const;

    /// Creates the group `path` and its missing parents ("pd/reduced"). Existing groups are
    /// fine; a dataset in the way is an error.
    void create_group(const std::string& path);

    /// Dense matrices: `matrix  rows x cols`, any storage order; stored as a rows x cols 2-D
    /// dataset. A matrix with zero rows or cols is stored with that shape.
    void write_matrix(const std::string& path, const Eigen::Ref<const RowMatX>& matrix);
    void write_matrix(const std::string& path, const Eigen::Ref<const RowMatXi>& matrix);
    void write_matrix(const std::string& path, const Eigen::Ref<const RowMatXl>& matrix);

    /// Vectors: `vector  #n`, stored as a 1-D dataset of #n entries.
    void write_vector(const std::string& path, const Eigen::Ref<const Eigen::VectorXd>& vector);
    void write_vector(const std::string& path, const Eigen::Ref<const Eigen::VectorXi>& vector);
    void write_vector(const std::string& path, const Eigen::Ref<const VecXl>& vector);

    /// A sparse matrix as a CSR group (see the header comment); need not be compressed.
    void write_sparse(const std::string& path, const SparseRowMat& matrix);

    /// UTF-8 text (JSON, a log) as a scalar string dataset. Text with a NUL byte is an error.
    void write_string(const std::string& path, const std::string& text);

    /// Scalar attributes on an existing object ("/" = the file). Strings are UTF-8 without NUL
    /// bytes, of any size (JSON options).
    void set_attribute(
        const std::string& object, const std::string& name, const std::string& value);
    void set_attribute(const std::string& object, const std::string& name, const char* value);
    void set_attribute(const std::string& object, const std::string& name, std::int64_t value);
    void set_attribute(const std::string& object, const std::string& name, int value);
    void set_attribute(const std::string& object, const std::string& name, double value);
    /// A 1-D integer attribute of values.size() entries (a CSR group's `shape` is one).
    void set_attribute(const std::string& object, const std::string& name,
        const std::vector<std::int64_t>& values);

    /// Series: a 64-bit float dataset that grows by one item per append(), for what a run saves
    /// every frame without holding the run in memory. `item_shape` is the shape of one item,
    /// each entry >= 1: {} (the dataset is #items), {n} (#items x n) or {rows, cols}
    /// (#items x rows x cols). The dataset is chunked along the items (chunks of up to 64
    /// items and about 256 KiB; an item above 1 MiB is split by rows), with the writer's gzip
    /// level; it starts with 0 items.
    /// `capacity` > 0 reserves that many items instead: the dataset has `capacity` items from
    /// the start, stored contiguously and uncompressed, its space allocated now (the file grows
    /// sparsely: no fill value is written), and append() writes item series_size() in place, up
    /// to `capacity`. Writing an item then changes no metadata of the file, so that a published
    /// file stays readable whenever the writer stops (the caller records how many items are
    /// valid, e.g. in an attribute it updates after a flush()).
    void create_series(
        const std::string& path, const std::vector<Index>& item_shape, Index capacity = 0);
    /// Appends one item to a series made by create_series: `item` holds the item row by row
    /// (1 x 1 for {}, 1 x n or n x 1 for {n}, rows x cols for {rows, cols}). On a failure the
    /// series keeps its previous items.
    void append(const std::string& path, const Eigen::Ref<const RowMatX>& item);
    /// Appends one value to a series of scalar items (item_shape {}).
    void append(const std::string& path, double value);
    /// How many items a series made by create_series holds.
    Index series_size(const std::string& path) const;

    /// Stamps the root with `format_name` (string) and `format_version` (integer, >= 1),
    /// which H5Reader::require_format checks.
    void stamp_format(const std::string& name, int version);

    /// Rewrites the existing scalar integer attribute `name` of `object` in place (no change to
    /// the file's structure, unlike set_attribute, which replaces it).
    void update_attribute(const std::string& object, const std::string& name, std::int64_t value);

    /// Writes everything HDF5 holds in memory to the file (to the operating system: no fsync).
    void flush();
    /// Flushes and renames the temporary over the target now, keeping the file open: later
    /// writes go to the target in place, a writer destroyed without commit() leaves it, and
    /// commit() only flushes and closes it. For files that must be readable while they are
    /// written (reserved series and update_attribute(), then flush()).
    void publish();

    /// Closes the file and renames it over the target (unless published). Throws mat::Error on
    /// failure (then no file is left at the target). No call other than target() may follow.
    void commit();

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

/// Reads an HDF5 file, checking every dataset's rank, element type and shape against what the
/// caller expects. Sizes passed as `H5Reader::any` are not checked.
class H5Reader {
public:
    static constexpr Index any = -1;

    /// Opens `path` read-only. Throws mat::Error if it does not exist, is not an HDF5 file, or
    /// is damaged (truncated) so that HDF5 cannot open it.
    explicit H5Reader(std::string path);
    ~H5Reader();
    H5Reader(const H5Reader&) = delete;
    H5Reader& operator=(const H5Reader&) = delete;
    H5Reader(H5Reader&&) noexcept;
    H5Reader& operator=(H5Reader&&) noexcept;

    const std::string& path() const;

    /// Checks the root's `format_name` and `format_version` (see H5Writer::stamp_format):
    /// throws mat::Error if the file is of another format or has no format stamp, or if its
    /// version is newer than `supported_version`. `program` names the reader in that message
    /// ("mat-run"). Returns the file's version (older versions are the caller's to handle).
    int require_format(const std::string& name, int supported_version,
        const std::string& program = "this program") const;

    /// True if `path` names an object (group or dataset); "/" always exists.
    bool has(const std::string& path) const;
    bool is_group(const std::string& path) const;
    bool is_dataset(const std::string& path) const;
    /// Names of a group's children, sorted. Throws if `group` is not a group.
    std::vector<std::string> list(const std::string& group) const;
    /// Dimensions of a dataset (empty for a scalar dataset).
    std::vector<Index> shape(const std::string& dataset) const;

    /// Dense matrices: a 2-D dataset of `rows x cols` (each may be `any`). Double reads accept
    /// any floating-point dataset; integer reads accept any integer dataset whose values fit.
    RowMatX read_matrix(const std::string& path, Index rows = any, Index cols = any) const;
    RowMatXi read_matrix_int(const std::string& path, Index rows = any, Index cols = any) const;
    RowMatXl read_matrix_int64(const std::string& path, Index rows = any, Index cols = any) const;

    /// Vectors: a 1-D dataset of `size` entries (or `any`).
    Eigen::VectorXd read_vector(const std::string& path, Index size = any) const;
    Eigen::VectorXi read_vector_int(const std::string& path, Index size = any) const;
    VecXl read_vector_int64(const std::string& path, Index size = any) const;

    /// Item `index` of a series (a dataset of rank 1, 2 or 3 whose first dimension counts the
    /// items, see H5Writer::create_series), without reading the others: 1 x 1 (rank 1), 1 x n
    /// (rank 2) or rows x cols (rank 3). `rows` and `cols` check the item's shape unless `any`.
    RowMatX read_series_item(
        const std::string& path, Index index, Index rows = any, Index cols = any) const;

    /// A CSR group written by write_sparse, of `rows x cols` (or `any`). Checks indptr
    /// (monotone, from 0 to nnz) and indices (in range, increasing within each row).
    SparseRowMat read_sparse(const std::string& path, Index rows = any, Index cols = any) const;

    /// A string dataset (fixed- or variable-length).
    std::string read_string(const std::string& path) const;

    /// Reads a dense matrix or vector straight into an Eigen type, checking the compile-time
    /// sizes: `read<MatX3>("mesh/rest_positions")` requires #rows x 3. `rows` (the size, for a
    /// vector) is checked unless `any`.
    template <typename Matrix> Matrix read(const std::string& path, Index rows = any) const;

    /// Attributes on an object ("/" = the file).
    bool has_attribute(const std::string& object, const std::string& name) const;
    /// Names of an object's attributes, sorted.
    std::vector<std::string> attribute_names(const std::string& object) const;
    std::string read_string_attribute(const std::string& object, const std::string& name) const;
    /// Any scalar integer attribute.
    std::int64_t read_int_attribute(const std::string& object, const std::string& name) const;
    /// Any scalar floating-point attribute (an integer one is a type error).
    double read_double_attribute(const std::string& object, const std::string& name) const;

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

template <typename Matrix> Matrix H5Reader::read(const std::string& path, Index rows) const
{
    using Scalar = typename Matrix::Scalar;
    static_assert(
        std::is_same_v<Scalar,
            double> || std::is_same_v<Scalar, int> || std::is_same_v<Scalar, std::int64_t>,
        "H5Reader::read: the scalar must be double, int or std::int64_t");
    if constexpr (Matrix::IsVectorAtCompileTime) {
        const Index size
            = Matrix::SizeAtCompileTime == Eigen::Dynamic ? rows : Index(Matrix::SizeAtCompileTime);
        if constexpr (std::is_same_v<Scalar, double>)
            return read_vector(path, size);
        else if constexpr (std::is_same_v<Scalar, int>)
            return read_vector_int(path, size);
        else
            return read_vector_int64(path, size);
    } else {
        const Index r
            = Matrix::RowsAtCompileTime == Eigen::Dynamic ? rows : Index(Matrix::RowsAtCompileTime);
        const Index c
            = Matrix::ColsAtCompileTime == Eigen::Dynamic ? any : Index(Matrix::ColsAtCompileTime);
        if constexpr (std::is_same_v<Scalar, double>)
            return read_matrix(path, r, c);
        else if constexpr (std::is_same_v<Scalar, int>)
            return read_matrix_int(path, r, c);
        else
            return read_matrix_int64(path, r, c);
    }
}

} // namespace mat
