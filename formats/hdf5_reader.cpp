// H5Reader: reads an HDF5 file, checking the rank, element type and shape of every dataset.

#include <algorithm>
#include <climits>
#include <filesystem>
#include <limits>

#include "common/error.hpp"
#include "formats/hdf5_file.hpp"
#include "formats/hdf5_internal.hpp"

namespace mat {

using h5::Hid;

namespace {
    template <typename Scalar> hid_t native_type()
    {
        if constexpr (std::is_same_v<Scalar, double>)
            return H5T_NATIVE_DOUBLE;
        else if constexpr (std::is_same_v<Scalar, int>)
            return H5T_NATIVE_INT;
        else
            return H5T_NATIVE_INT64;
    }

    std::string describe_expected(int rank, Index e0, Index e1)
    {
        const auto size
            = [](Index e) { return e == H5Reader::any ? std::string("?") : std::to_string(e); };
        return rank == 1 ? size(e0) : size(e0) + " x " + size(e1);
    }

    herr_t add_link_name(hid_t, const char* name, const H5L_info_t*, void* data)
    {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
    }

    herr_t add_attribute_name(hid_t, const char* name, const H5A_info_t*, void* data)
    {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
    }
} // namespace

struct H5Reader::Impl {
    std::string path;
    Hid file;

    explicit Impl(std::string path_)
        : path(std::move(path_))
    {
        h5::silence_errors();
        std::error_code ec;
        if (!std::filesystem::exists(path, ec))
            throw_error("{}: cannot open: no such file", path);
        if (std::filesystem::is_directory(path, ec))
            throw_error("{}: cannot open: it is a directory", path);
        const htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
        if (is_hdf5 <= 0) {
            const std::string why = h5::reason();
            if (is_hdf5 < 0)
                throw_error("{}: cannot open: {}", path, why);
            throw_error("{}: not an HDF5 file (no HDF5 signature)", path);
        }
        const Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
        if (!fapl.valid() || H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG) < 0)
            throw_error("{}: cannot set up HDF5 file properties: {}", path, h5::reason());
#if H5_VERSION_GE(1, 10, 7)
        // Reading needs no lock; do not fail on file systems without locking.
        H5Pset_file_locking(fapl.get(), false, true);
#endif
        file = Hid(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
        if (!file.valid())
            throw_error(
                "{}: cannot open HDF5 file, it is damaged or truncated ({})", path, h5::reason());
    }

    std::string normalize(const std::string& raw) const
    {
        return h5::normalize(path, raw);
    }

    Hid open_object(const std::string& object) const
    {
        if (h5::object_type(file.get(), object) == H5I_BADID)
            throw_error("{}: no object '{}'", path, object);
        Hid handle(H5Oopen(file.get(), object.c_str(), H5P_DEFAULT), H5Oclose);
        if (!handle.valid())
            throw_error("{}: cannot open '{}': {}", path, object, h5::reason());
        return handle;
    }

    Hid open_dataset(const std::string& dataset) const
    {
        const H5I_type_t type = h5::object_type(file.get(), dataset);
        if (type == H5I_BADID)
            throw_error("{}: no dataset '{}'", path, dataset);
        if (type != H5I_DATASET)
            throw_error("{}: '{}' is a {}, expected a dataset", path, dataset,
                type == H5I_GROUP ? "group" : "named type");
        Hid handle(H5Dopen2(file.get(), dataset.c_str(), H5P_DEFAULT), H5Dclose);
        if (!handle.valid())
            throw_error("{}: cannot open dataset '{}': {}", path, dataset, h5::reason());
        return handle;
    }

    std::vector<hsize_t> dims_of(hid_t space, const std::string& what) const
    {
        const int rank = H5Sget_simple_extent_ndims(space);
        if (rank < 0)
            throw_error("{}: cannot read the shape of {}: {}", path, what, h5::reason());
        std::vector<hsize_t> dims(std::size_t(rank), 0);
        if (rank > 0 && H5Sget_simple_extent_dims(space, dims.data(), nullptr) < 0)
            throw_error("{}: cannot read the shape of {}: {}", path, what, h5::reason());
        return dims;
    }

    // Reads `count` numbers of `type` through `read` (an H5Dread or H5Aread on a memory type
    // and buffer) into `out`, checking the class and that integers fit in Scalar.
    template <typename Scalar, typename Read>
    void read_numbers(
        const std::string& what, hid_t type, std::size_t count, Scalar* out, Read&& read) const
    {
        const H5T_class_t type_class = H5Tget_class(type);
        if constexpr (std::is_same_v<Scalar, double>) {
            if (type_class != H5T_FLOAT)
                throw_error("{}: {} holds {}, expected floating-point numbers", path, what,
                    h5::describe_type(type));
            if (count > 0 && read(H5T_NATIVE_DOUBLE, out) < 0)
                throw_error("{}: cannot read {}: {}", path, what, h5::reason());
        } else {
            if (type_class != H5T_INTEGER)
                throw_error(
                    "{}: {} holds {}, expected integers", path, what, h5::describe_type(type));
            const std::size_t size = H5Tget_size(type);
            const bool is_unsigned = H5Tget_sign(type) == H5T_SGN_NONE;
            const bool lossless = is_unsigned ? size < sizeof(Scalar) : size <= sizeof(Scalar);
            if (count == 0)
                return;
            if (lossless) {
                if (read(native_type<Scalar>(), out) < 0)
                    throw_error("{}: cannot read {}: {}", path, what, h5::reason());
                return;
            }
            const auto narrow = [&](auto* wide) {
                using Wide = std::remove_pointer_t<decltype(wide)>;
                for (std::size_t i = 0; i < count; ++i) {
                    bool fits = false;
                    if constexpr (std::is_signed_v<Wide>)
                        fits = wide[i] >= Wide(std::numeric_limits<Scalar>::min())
                            && wide[i] <= Wide(std::numeric_limits<Scalar>::max());
                    else
                        fits = wide[i] <= Wide(std::numeric_limits<Scalar>::max());
                    if (!fits)
                        throw_error("{}: {}: value {} at entry {} does not fit in a {}-bit integer",
                            path, what, wide[i], i, 8 * sizeof(Scalar));
                    out[i] = Scalar(wide[i]);
                }
            };
            if (is_unsigned) {
                std::vector<std::uint64_t> wide(count);
                if (read(H5T_NATIVE_UINT64, wide.data()) < 0)
                    throw_error("{}: cannot read {}: {}", path, what, h5::reason());
                narrow(wide.data());
            } else {
                std::vector<std::int64_t> wide(count);
                if (read(H5T_NATIVE_INT64, wide.data()) < 0)
                    throw_error("{}: cannot read {}: {}", path, what, h5::reason());
                narrow(wide.data());
            }
        }
    }

    /// A dataset opened for reading, with its type and shape.
    struct Opened {
        std::string what; ///< "dataset '/path'", for messages
        Hid dataset, space, type;
        std::vector<hsize_t> dims;
    };

    Opened open_with_shape(const std::string& raw) const
    {
        Opened opened;
        const std::string dataset_path = normalize(raw);
        opened.dataset = open_dataset(dataset_path);
        opened.space = Hid(H5Dget_space(opened.dataset.get()), H5Sclose);
        opened.type = Hid(H5Dget_type(opened.dataset.get()), H5Tclose);
        if (!opened.space.valid() || !opened.type.valid())
            throw_error("{}: cannot read dataset '{}': {}", path, dataset_path, h5::reason());
        opened.what = "dataset '" + dataset_path + "'";
        opened.dims = dims_of(opened.space.get(), opened.what);
        check_storage(opened);
        return opened;
    }

    // A damaged file can claim more values than a dataset stores; HDF5 1.10 may then read past
    // its own buffers (a heap overflow found by fuzzing, docs/building.md, Fuzzing). H5Writer
    // writes every value: a dataset without filters stores at least its shape's bytes (whole
    // chunks), a compressed one at least some bytes once it has values.
    void check_storage(const Opened& opened) const
    {
        const Hid plist(H5Dget_create_plist(opened.dataset.get()), H5Pclose);
        if (!plist.valid())
            throw_error("{}: cannot read {}: {}", path, opened.what, h5::reason());
        long double needed = H5Tget_size(opened.type.get());
        for (const hsize_t d : opened.dims)
            needed *= static_cast<long double>(d);
        const long double stored = H5Dget_storage_size(opened.dataset.get());
        const bool filtered = H5Pget_nfilters(plist.get()) > 0;
        if (filtered ? (needed > 0 && stored == 0) : needed > stored)
            throw_error("{}: {} has shape {} ({:.0f} bytes) but stores {:.0f} bytes: the file "
                        "is damaged",
                path, opened.what, h5::describe_dims(opened.dims), double(needed), double(stored));
    }

    // Reads a rank-1 (into a vector) or rank-2 (into a row-major matrix) dataset of the
    // expected shape (H5Reader::any = unchecked).
    template <typename Out> Out read_dense(const std::string& raw, Index e0, Index e1 = any) const
    {
        using Scalar = typename Out::Scalar;
        constexpr int rank = Out::IsVectorAtCompileTime ? 1 : 2;
        const Opened opened = open_with_shape(raw);
        const Hid& dataset = opened.dataset;
        const Hid& type = opened.type;
        const std::string& what = opened.what;
        const std::vector<hsize_t>& dims = opened.dims;
        if (int(dims.size()) != rank) {
            const bool sized = e0 != any || (rank == 2 && e1 != any);
            throw_error("{}: {} has shape {}, expected a {}-D dataset{}{}", path, what,
                h5::describe_dims(dims), rank, sized ? " of " : "",
                sized ? describe_expected(rank, e0, e1) : std::string());
        }
        const bool shape_ok = (e0 == any || hsize_t(e0) == dims[0])
            && (rank == 1 || e1 == any || hsize_t(e1) == dims[1]);
        if (!shape_ok)
            throw_error("{}: {} has shape {}, expected {}", path, what, h5::describe_dims(dims),
                describe_expected(rank, e0, e1));
        Out out;
        if constexpr (rank == 1)
            out.resize(Index(dims[0]));
        else
            out.resize(Index(dims[0]), Index(dims[1]));
        read_numbers<Scalar>(what, type.get(), std::size_t(out.size()), out.data(),
            [&](hid_t memory_type, void* buffer) {
                return H5Dread(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
            });
        return out;
    }

    RowMatX read_series_item(const std::string& raw, Index index, Index rows, Index cols) const
    {
        const Opened opened = open_with_shape(raw);
        const Hid& dataset = opened.dataset;
        const Hid& space = opened.space;
        const Hid& type = opened.type;
        const std::string& what = opened.what;
        const std::vector<hsize_t>& dims = opened.dims;
        if (dims.empty() || dims.size() > 3)
            throw_error("{}: {} has shape {}, expected a series (1-D, 2-D or 3-D)", path, what,
                h5::describe_dims(dims));
        const Index item_rows = dims.size() == 3 ? Index(dims[1]) : 1;
        const Index item_cols = dims.size() == 1 ? 1 : Index(dims.back());
        if ((rows != H5Reader::any && rows != item_rows)
            || (cols != H5Reader::any && cols != item_cols))
            throw_error("{}: {} has shape {}, expected items of {}", path, what,
                h5::describe_dims(dims), describe_expected(2, rows, cols));
        if (index < 0 || hsize_t(index) >= dims[0])
            throw_error("{}: {} has {} items, item {} does not exist", path, what, dims[0], index);
        std::vector<hsize_t> start(dims.size(), 0);
        start[0] = hsize_t(index);
        std::vector<hsize_t> count = dims;
        count[0] = 1;
        const hsize_t values = hsize_t(item_rows * item_cols);
        const Hid memory_space(H5Screate_simple(1, &values, nullptr), H5Sclose);
        if (!memory_space.valid()
            || H5Sselect_hyperslab(
                   space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr)
                < 0)
            throw_error("{}: cannot read {}: {}", path, what, h5::reason());
        RowMatX out(item_rows, item_cols);
        read_numbers<double>(fmt::format("item {} of {}", index, what), type.get(),
            std::size_t(values), out.data(), [&](hid_t memory_type, void* buffer) {
                return H5Dread(dataset.get(), memory_type, memory_space.get(), space.get(),
                    H5P_DEFAULT, buffer);
            });
        return out;
    }

    Hid open_attribute(const std::string& object, const std::string& name) const
    {
        const Hid handle = open_object(object);
        const htri_t exists = H5Aexists(handle.get(), name.c_str());
        if (exists < 0)
            throw_error(
                "{}: cannot read attribute '{}' of '{}': {}", path, name, object, h5::reason());
        if (exists == 0)
            throw_error("{}: no attribute '{}' on '{}'", path, name, object);
        Hid attribute(H5Aopen(handle.get(), name.c_str(), H5P_DEFAULT), H5Aclose);
        if (!attribute.valid())
            throw_error(
                "{}: cannot read attribute '{}' of '{}': {}", path, name, object, h5::reason());
        return attribute;
    }

    // Reads attribute `name` of `raw_object`: `count` numbers (count 1: a scalar or 1 entry).
    template <typename Scalar>
    std::vector<Scalar> read_attribute(
        const std::string& raw_object, const std::string& name, std::size_t count) const
    {
        const std::string object = normalize(raw_object);
        const Hid attribute = open_attribute(object, name);
        const Hid space(H5Aget_space(attribute.get()), H5Sclose);
        const Hid type(H5Aget_type(attribute.get()), H5Tclose);
        const std::string what = "attribute '" + name + "' of '" + object + "'";
        if (!space.valid() || !type.valid())
            throw_error("{}: cannot read {}: {}", path, what, h5::reason());
        const hssize_t found = H5Sget_simple_extent_npoints(space.get());
        if (found != hssize_t(count))
            throw_error("{}: {} has {} values, expected {}", path, what, found, count);
        std::vector<Scalar> out(count);
        read_numbers<Scalar>(
            what, type.get(), count, out.data(), [&](hid_t memory_type, void* buffer) {
                return H5Aread(attribute.get(), memory_type, buffer);
            });
        return out;
    }
};

H5Reader::H5Reader(std::string path)
    : m_impl(std::make_unique<Impl>(std::move(path)))
{
}

H5Reader::~H5Reader() = default;
H5Reader::H5Reader(H5Reader&&) noexcept = default;
H5Reader& H5Reader::operator=(H5Reader&&) noexcept = default;

const std::string& H5Reader::path() const
{
    return m_impl->path;
}

int H5Reader::require_format(
    const std::string& name, int supported_version, const std::string& program) const
{
    const std::string& file = m_impl->path;
    if (!has_attribute("/", "format_name"))
        throw_error("{}: not a {} file (its root has no 'format_name' attribute)", file, name);
    const std::string found = read_string_attribute("/", "format_name");
    if (found != name)
        throw_error("{}: is a '{}' file, expected a '{}' file", file, found, name);
    const std::int64_t version = read_int_attribute("/", "format_version");
    if (version < 1 || version > INT_MAX)
        throw_error("{}: invalid {} format_version {}", file, name, version);
    if (version > supported_version)
        throw_error("{}: {} format version {} is newer than {} supports ({}); re-create the file "
                    "or update {}",
            file, name, version, program, supported_version, program);
    return int(version);
}

bool H5Reader::has(const std::string& path) const
{
    return h5::object_type(m_impl->file.get(), m_impl->normalize(path)) != H5I_BADID;
}

bool H5Reader::is_group(const std::string& path) const
{
    return h5::object_type(m_impl->file.get(), m_impl->normalize(path)) == H5I_GROUP;
}

bool H5Reader::is_dataset(const std::string& path) const
{
    return h5::object_type(m_impl->file.get(), m_impl->normalize(path)) == H5I_DATASET;
}

std::vector<std::string> H5Reader::list(const std::string& raw_group) const
{
    const std::string group = m_impl->normalize(raw_group);
    const H5I_type_t type = h5::object_type(m_impl->file.get(), group);
    if (type == H5I_BADID)
        throw_error("{}: no group '{}'", m_impl->path, group);
    if (type != H5I_GROUP)
        throw_error("{}: '{}' is not a group", m_impl->path, group);
    const Hid handle(H5Gopen2(m_impl->file.get(), group.c_str(), H5P_DEFAULT), H5Gclose);
    std::vector<std::string> names;
    if (!handle.valid()
        || H5Literate(handle.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, add_link_name, &names) < 0)
        throw_error("{}: cannot list group '{}': {}", m_impl->path, group, h5::reason());
    std::sort(names.begin(), names.end());
    return names;
}

RowMatX H5Reader::read_series_item(
    const std::string& path, Index index, Index rows, Index cols) const
{
    return m_impl->read_series_item(path, index, rows, cols);
}

std::vector<Index> H5Reader::shape(const std::string& raw) const
{
    const std::string dataset_path = m_impl->normalize(raw);
    const Hid dataset = m_impl->open_dataset(dataset_path);
    const Hid space(H5Dget_space(dataset.get()), H5Sclose);
    if (!space.valid())
        throw_error("{}: cannot read dataset '{}': {}", m_impl->path, dataset_path, h5::reason());
    std::vector<Index> out;
    for (hsize_t d : m_impl->dims_of(space.get(), "dataset '" + dataset_path + "'"))
        out.push_back(Index(d));
    return out;
}

RowMatX H5Reader::read_matrix(const std::string& path, Index rows, Index cols) const
{
    return m_impl->read_dense<RowMatX>(path, rows, cols);
}

RowMatXi H5Reader::read_matrix_int(const std::string& path, Index rows, Index cols) const
{
    return m_impl->read_dense<RowMatXi>(path, rows, cols);
}

RowMatXl H5Reader::read_matrix_int64(const std::string& path, Index rows, Index cols) const
{
    return m_impl->read_dense<RowMatXl>(path, rows, cols);
}

Eigen::VectorXd H5Reader::read_vector(const std::string& path, Index size) const
{
    return m_impl->read_dense<Eigen::VectorXd>(path, size);
}

Eigen::VectorXi H5Reader::read_vector_int(const std::string& path, Index size) const
{
    return m_impl->read_dense<Eigen::VectorXi>(path, size);
}

VecXl H5Reader::read_vector_int64(const std::string& path, Index size) const
{
    return m_impl->read_dense<VecXl>(path, size);
}

SparseRowMat H5Reader::read_sparse(const std::string& raw, Index rows, Index cols) const
{
    const std::string& file = m_impl->path;
    const std::string group = m_impl->normalize(raw);
    const H5I_type_t type = h5::object_type(m_impl->file.get(), group);
    if (type == H5I_BADID)
        throw_error("{}: no sparse matrix '{}'", file, group);
    if (type != H5I_GROUP || !has_attribute(group, "encoding")
        || read_string_attribute(group, "encoding") != "csr")
        throw_error(
            "{}: '{}' is not a CSR sparse matrix (a group with encoding = \"csr\")", file, group);
    const std::vector<std::int64_t> shape = m_impl->read_attribute<std::int64_t>(group, "shape", 2);
    if (shape[0] < 0 || shape[1] < 0 || shape[0] >= INT_MAX || shape[1] >= INT_MAX)
        throw_error(
            "{}: sparse matrix '{}' has invalid shape {} x {}", file, group, shape[0], shape[1]);
    if ((rows != any && rows != shape[0]) || (cols != any && cols != shape[1]))
        throw_error("{}: sparse matrix '{}' has shape {} x {}, expected {}", file, group, shape[0],
            shape[1], describe_expected(2, rows, cols));

    const Eigen::VectorXi indptr = read_vector_int(group + "/indptr", shape[0] + 1);
    const Eigen::VectorXi indices = read_vector_int(group + "/indices");
    const Eigen::VectorXd data = read_vector(group + "/data", indices.size());
    const Index nnz = indices.size();
    if (indptr[0] != 0 || indptr[shape[0]] != nnz)
        throw_error("{}: sparse matrix '{}': indptr runs from {} to {}, expected 0 to {} (nnz)",
            file, group, indptr[0], indptr[shape[0]], nnz);
    for (Index row = 0; row < shape[0]; ++row) {
        if (indptr[row + 1] < indptr[row])
            throw_error("{}: sparse matrix '{}': indptr decreases at row {}", file, group, row);
        for (Index k = indptr[row]; k < indptr[row + 1]; ++k) {
            if (indices[k] < 0 || indices[k] >= shape[1])
                throw_error("{}: sparse matrix '{}': column {} of entry {} (row {}) is out of "
                            "range 0..{}",
                    file, group, indices[k], k, row, shape[1] - 1);
            if (k > indptr[row] && indices[k] <= indices[k - 1])
                throw_error("{}: sparse matrix '{}': columns of row {} are not increasing at "
                            "entry {}",
                    file, group, row, k);
        }
    }
    const Eigen::Map<const SparseRowMat> view(
        shape[0], shape[1], nnz, indptr.data(), indices.data(), data.data());
    return SparseRowMat(view);
}

std::string H5Reader::read_string(const std::string& raw) const
{
    const std::string dataset_path = m_impl->normalize(raw);
    const Hid dataset = m_impl->open_dataset(dataset_path);
    std::string out;
    const std::string error = h5::read_text(dataset.get(), false, out);
    if (!error.empty())
        throw_error("{}: dataset '{}': {}", m_impl->path, dataset_path, error);
    return out;
}

bool H5Reader::has_attribute(const std::string& raw_object, const std::string& name) const
{
    const std::string object = m_impl->normalize(raw_object);
    if (h5::object_type(m_impl->file.get(), object) == H5I_BADID)
        return false;
    const htri_t exists
        = H5Aexists_by_name(m_impl->file.get(), object.c_str(), name.c_str(), H5P_DEFAULT);
    if (exists < 0)
        throw_error("{}: cannot look up attribute '{}' of '{}': {}", m_impl->path, name, object,
            h5::reason());
    return exists > 0;
}

std::vector<std::string> H5Reader::attribute_names(const std::string& raw_object) const
{
    const std::string object = m_impl->normalize(raw_object);
    const Hid handle = m_impl->open_object(object);
    std::vector<std::string> names;
    if (H5Aiterate2(handle.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, add_attribute_name, &names)
        < 0)
        throw_error(
            "{}: cannot list the attributes of '{}': {}", m_impl->path, object, h5::reason());
    std::sort(names.begin(), names.end());
    return names;
}

std::string H5Reader::read_string_attribute(
    const std::string& raw_object, const std::string& name) const
{
    const std::string object = m_impl->normalize(raw_object);
    const Hid attribute = m_impl->open_attribute(object, name);
    std::string out;
    const std::string error = h5::read_text(attribute.get(), true, out);
    if (!error.empty())
        throw_error("{}: attribute '{}' of '{}': {}", m_impl->path, name, object, error);
    return out;
}

std::int64_t H5Reader::read_int_attribute(const std::string& object, const std::string& name) const
{
    return m_impl->read_attribute<std::int64_t>(object, name, 1)[0];
}

double H5Reader::read_double_attribute(const std::string& object, const std::string& name) const
{
    return m_impl->read_attribute<double>(object, name, 1)[0];
}

} // namespace mat
