// H5Writer: an HDF5 file written into an AtomicFile temporary, renamed on commit().

#include <algorithm>
#include <map>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/atomic_file.hpp"
#include "formats/hdf5_file.hpp"
#include "formats/hdf5_internal.hpp"

namespace mat {

using h5::Hid;

namespace {
    // Aim for chunks of about 1 MiB: large enough for gzip, small enough for HDF5's chunk cache.
    constexpr hsize_t chunk_bytes = 1 << 20;

    bool deflate_available()
    {
        static const bool available = [] {
            unsigned flags = 0;
            const bool ok = H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0
                && H5Zget_filter_info(H5Z_FILTER_DEFLATE, &flags) >= 0
                && (flags & H5Z_FILTER_CONFIG_ENCODE_ENABLED);
            H5Eclear2(H5E_DEFAULT);
            if (!ok)
                logger().warn(
                    "HDF5 has no gzip (deflate) filter: datasets are stored uncompressed");
            return ok;
        }();
        return available;
    }

    // Chunk shape for `dims` (rank 1 or 2) holding about chunk_bytes: whole rows when they fit.
    std::vector<hsize_t> chunk_shape(const std::vector<hsize_t>& dims, std::size_t element_size)
    {
        const hsize_t per_chunk = std::max<hsize_t>(1, chunk_bytes / element_size);
        if (dims.size() == 1)
            return { std::min(dims[0], per_chunk) };
        const hsize_t cols = dims[1];
        if (cols <= per_chunk)
            return { std::clamp<hsize_t>(per_chunk / cols, 1, dims[0]), cols };
        return { 1, per_chunk };
    }
} // namespace

struct H5Writer::Impl {
    std::string target;
    H5WriterOptions options;
    AtomicFile atomic;
    Hid file; // after `atomic`: closed before the temporary is removed
    std::map<std::string, h5::Series> series; // after `file`: closed before the file
    bool committed = false;
    bool published = false; ///< renamed to the target already (publish())

    Impl(std::string target_, H5WriterOptions options_)
        : target(std::move(target_))
        , options(options_)
        , atomic(target)
    {
        h5::silence_errors();
        if (options.gzip_level < 0 || options.gzip_level > 9)
            throw_error("{}: gzip level {} is out of range 0..9", target, options.gzip_level);
        const Hid fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
        const Hid fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
        // The 1.8 object format: readable by HDF5 >= 1.8 and h5py, and it keeps attributes of
        // any size (JSON options) in dense storage. No timestamps on the root group.
        if (!fcpl.valid() || !fapl.valid() || H5Pset_obj_track_times(fcpl.get(), false) < 0
            || H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V18, H5F_LIBVER_V18) < 0
            || H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG) < 0
            || (!options.file_locking && H5Pset_file_locking(fapl.get(), false, true) < 0))
            throw_error("{}: cannot set up HDF5 file properties: {}", target, h5::reason());
        file = Hid(
            H5Fcreate(atomic.temp_path().c_str(), H5F_ACC_EXCL, fcpl.get(), fapl.get()), H5Fclose);
        if (!file.valid())
            throw_error("{}: cannot create HDF5 file: {}", target, h5::reason());
    }

    void check_open() const
    {
        if (committed)
            throw_error("{}: cannot write: the file was already committed", target);
    }

    Hid object_creation_list(hid_t list_class) const
    {
        Hid list(H5Pcreate(list_class), H5Pclose);
        if (!list.valid() || H5Pset_obj_track_times(list.get(), false) < 0)
            throw_error("{}: cannot set up HDF5 properties: {}", target, h5::reason());
        return list;
    }

    // Creates the group `path` (normalised) and its missing parents, for writing `what`.
    void make_groups(const std::string& path, const std::string& what)
    {
        const Hid gcpl = object_creation_list(H5P_GROUP_CREATE);
        for (const std::string& prefix : h5::prefixes(path)) {
            const H5I_type_t type = h5::object_type(file.get(), prefix);
            if (type == H5I_GROUP)
                continue;
            if (type != H5I_BADID)
                throw_error("{}: cannot write {}: '{}' is a {}, not a group", target, what, prefix,
                    type == H5I_DATASET ? "dataset" : "named type");
            const Hid group(
                H5Gcreate2(file.get(), prefix.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT),
                H5Gclose);
            if (!group.valid())
                throw_error("{}: cannot create group '{}': {}", target, prefix, h5::reason());
        }
    }

    std::string parent_of(const std::string& path) const
    {
        const std::size_t slash = path.rfind('/');
        return slash == 0 ? std::string("/") : path.substr(0, slash);
    }

    // Writes a new dataset of `dims` (rank 0, 1 or 2) from `data` (row by row).
    void write_dataset(const std::string& raw_path, hid_t file_type, hid_t memory_type,
        const std::vector<hsize_t>& dims, const void* data)
    {
        check_open();
        const std::string path = h5::normalize(target, raw_path);
        if (path == "/")
            throw_error("{}: cannot write a dataset at the root '/'", target);
        make_groups(parent_of(path), "dataset '" + path + "'");
        if (h5::object_type(file.get(), path) != H5I_BADID)
            throw_error("{}: cannot write dataset '{}': it already exists", target, path);

        hsize_t count = 1;
        for (hsize_t d : dims)
            count *= d;
        const std::size_t element_size = H5Tget_size(file_type);
        const Hid space(dims.empty() ? H5Screate(H5S_SCALAR)
                                     : H5Screate_simple(int(dims.size()), dims.data(), nullptr),
            H5Sclose);
        const Hid dcpl = object_creation_list(H5P_DATASET_CREATE);
        if (!space.valid())
            throw_error("{}: cannot write dataset '{}': {}", target, path, h5::reason());
        const bool compress = options.gzip_level > 0 && !dims.empty() && count > 0
            && hsize_t(std::max<std::int64_t>(options.compress_min_bytes, 0))
                <= count * element_size
            && deflate_available();
        if (compress) {
            const std::vector<hsize_t> chunk = chunk_shape(dims, element_size);
            if (H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data()) < 0
                || H5Pset_shuffle(dcpl.get()) < 0
                || H5Pset_deflate(dcpl.get(), unsigned(options.gzip_level)) < 0)
                throw_error("{}: cannot set up compression for dataset '{}': {}", target, path,
                    h5::reason());
        }
        const Hid dataset(H5Dcreate2(file.get(), path.c_str(), file_type, space.get(), H5P_DEFAULT,
                              dcpl.get(), H5P_DEFAULT),
            H5Dclose);
        if (!dataset.valid())
            throw_error("{}: cannot create dataset '{}': {}", target, path, h5::reason());
        if (count > 0
            && H5Dwrite(dataset.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
            throw_error("{}: cannot write dataset '{}': {}", target, path, h5::reason());
    }

    // Sets attribute `name` of `raw_object` (replacing it) to `dims` values of `data`.
    void write_attribute(const std::string& raw_object, const std::string& name, hid_t file_type,
        hid_t memory_type, const std::vector<hsize_t>& dims, const void* data)
    {
        check_open();
        const std::string object = h5::normalize(target, raw_object);
        if (name.empty())
            throw_error("{}: attribute of '{}': empty name", target, object);
        if (h5::object_type(file.get(), object) == H5I_BADID)
            throw_error("{}: cannot set attribute '{}': no object '{}'", target, name, object);
        const htri_t exists
            = H5Aexists_by_name(file.get(), object.c_str(), name.c_str(), H5P_DEFAULT);
        if (exists < 0
            || (exists > 0
                && H5Adelete_by_name(file.get(), object.c_str(), name.c_str(), H5P_DEFAULT) < 0))
            throw_error("{}: cannot replace attribute '{}' of '{}': {}", target, name, object,
                h5::reason());
        const Hid space(dims.empty() ? H5Screate(H5S_SCALAR)
                                     : H5Screate_simple(int(dims.size()), dims.data(), nullptr),
            H5Sclose);
        if (!space.valid())
            throw_error(
                "{}: cannot set attribute '{}' of '{}': {}", target, name, object, h5::reason());
        const Hid attribute(H5Acreate_by_name(file.get(), object.c_str(), name.c_str(), file_type,
                                space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
            H5Aclose);
        if (!attribute.valid() || H5Awrite(attribute.get(), memory_type, data) < 0)
            throw_error(
                "{}: cannot set attribute '{}' of '{}': {}", target, name, object, h5::reason());
    }

    Hid text_type(const std::string& what, const std::string& text) const
    {
        if (text.find('\0') != std::string::npos)
            throw_error("{}: cannot write {}: the text contains a NUL byte", target, what);
        Hid type = h5::string_type(text);
        if (!type.valid())
            throw_error("{}: cannot write {}: {}", target, what, h5::reason());
        return type;
    }

    template <typename Matrix>
    void write_dense(
        const std::string& path, const Matrix& matrix, hid_t file_type, hid_t memory_type)
    {
        const std::vector<hsize_t> dims { hsize_t(matrix.rows()), hsize_t(matrix.cols()) };
        // A Ref may view a block whose rows are not adjacent: make them so.
        if (matrix.rows() > 1 && matrix.outerStride() != matrix.cols()) {
            const typename Matrix::PlainObject packed = matrix;
            write_dataset(path, file_type, memory_type, dims, packed.data());
        } else {
            write_dataset(path, file_type, memory_type, dims, matrix.data());
        }
    }

    void create_series(
        const std::string& raw_path, const std::vector<Index>& item_shape, Index capacity)
    {
        check_open();
        const std::string path = h5::normalize(target, raw_path);
        if (path == "/")
            throw_error("{}: cannot write a dataset at the root '/'", target);
        if (item_shape.size() > 2)
            throw_error("{}: cannot create series '{}': items of rank {}, expected 0, 1 or 2",
                target, path, item_shape.size());
        std::vector<hsize_t> item_dims;
        for (Index d : item_shape) {
            if (d < 1)
                throw_error("{}: cannot create series '{}': item dimension {}, expected >= 1",
                    target, path, d);
            item_dims.push_back(hsize_t(d));
        }
        make_groups(parent_of(path), "series '" + path + "'");
        if (h5::object_type(file.get(), path) != H5I_BADID)
            throw_error("{}: cannot create series '{}': it already exists", target, path);

        if (capacity < 0)
            throw_error("{}: cannot create series '{}': capacity {}, expected >= 0", target, path,
                capacity);
        const Hid dcpl = object_creation_list(H5P_DATASET_CREATE);
        if (capacity == 0 && options.gzip_level > 0 && deflate_available()
            && (H5Pset_shuffle(dcpl.get()) < 0
                || H5Pset_deflate(dcpl.get(), unsigned(options.gzip_level)) < 0))
            throw_error(
                "{}: cannot set up compression for series '{}': {}", target, path, h5::reason());
        series[path]
            = h5::create_series(file.get(), dcpl.get(), target, path, item_dims, hsize_t(capacity));
    }

    h5::Series& find_series(const std::string& path, const char* what)
    {
        const auto found = series.find(path);
        if (found == series.end())
            throw_error(
                "{}: cannot {} '{}': not a series made by create_series", target, what, path);
        return found->second;
    }

    // Appends one item of `rows x cols` values (`data`, row by row) to series `raw_path`.
    void append(const std::string& raw_path, const double* data, Index rows, Index cols)
    {
        check_open();
        const std::string path = h5::normalize(target, raw_path);
        h5::append_to_series(find_series(path, "append to"), target, path, data, rows, cols);
    }

    template <typename Vector>
    void write_1d(const std::string& path, const Vector& vector, hid_t file_type, hid_t memory_type)
    {
        write_dataset(path, file_type, memory_type, { hsize_t(vector.size()) }, vector.data());
    }
};

H5Writer::H5Writer(std::string target, H5WriterOptions options)
    : m_impl(std::make_unique<Impl>(std::move(target), options))
{
}

H5Writer::~H5Writer() = default;
H5Writer::H5Writer(H5Writer&&) noexcept = default;
H5Writer& H5Writer::operator=(H5Writer&&) noexcept = default;

const std::string& H5Writer::target() const
{
    return m_impl->target;
}

void H5Writer::create_group(const std::string& path)
{
    m_impl->check_open();
    const std::string group = h5::normalize(m_impl->target, path);
    m_impl->make_groups(group, "group '" + group + "'");
}

void H5Writer::write_matrix(const std::string& path, const Eigen::Ref<const RowMatX>& matrix)
{
    m_impl->write_dense(path, matrix, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE);
}

void H5Writer::write_matrix(const std::string& path, const Eigen::Ref<const RowMatXi>& matrix)
{
    m_impl->write_dense(path, matrix, H5T_STD_I32LE, H5T_NATIVE_INT);
}

void H5Writer::write_matrix(const std::string& path, const Eigen::Ref<const RowMatXl>& matrix)
{
    m_impl->write_dense(path, matrix, H5T_STD_I64LE, H5T_NATIVE_INT64);
}

void H5Writer::write_vector(
    const std::string& path, const Eigen::Ref<const Eigen::VectorXd>& vector)
{
    m_impl->write_1d(path, vector, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE);
}

void H5Writer::write_vector(
    const std::string& path, const Eigen::Ref<const Eigen::VectorXi>& vector)
{
    m_impl->write_1d(path, vector, H5T_STD_I32LE, H5T_NATIVE_INT);
}

void H5Writer::write_vector(const std::string& path, const Eigen::Ref<const VecXl>& vector)
{
    m_impl->write_1d(path, vector, H5T_STD_I64LE, H5T_NATIVE_INT64);
}

void H5Writer::create_series(
    const std::string& path, const std::vector<Index>& item_shape, Index capacity)
{
    m_impl->create_series(path, item_shape, capacity);
}

void H5Writer::append(const std::string& path, const Eigen::Ref<const RowMatX>& item)
{
    // A Ref may view a block whose rows are not adjacent: make them so.
    if (item.rows() > 1 && item.outerStride() != item.cols()) {
        const RowMatX packed = item;
        m_impl->append(path, packed.data(), packed.rows(), packed.cols());
    } else {
        m_impl->append(path, item.data(), item.rows(), item.cols());
    }
}

void H5Writer::append(const std::string& path, double value)
{
    m_impl->append(path, &value, 1, 1);
}

Index H5Writer::series_size(const std::string& path) const
{
    return Index(m_impl->find_series(h5::normalize(m_impl->target, path), "get the size of").size);
}

void H5Writer::write_sparse(const std::string& path, const SparseRowMat& matrix)
{
    static_assert(sizeof(SparseRowMat::StorageIndex) == sizeof(int));
    Impl& impl = *m_impl;
    impl.check_open();
    const std::string group = h5::normalize(impl.target, path);
    if (h5::object_type(impl.file.get(), group) != H5I_BADID)
        throw_error("{}: cannot write sparse matrix '{}': it already exists", impl.target, group);
    SparseRowMat compressed;
    const SparseRowMat* source = &matrix;
    if (!matrix.isCompressed()) {
        compressed = matrix;
        compressed.makeCompressed();
        source = &compressed;
    }
    const hsize_t rows = hsize_t(source->rows());
    const hsize_t nnz = hsize_t(source->nonZeros());
    impl.make_groups(group, "sparse matrix '" + group + "'");
    impl.write_dataset(
        group + "/indptr", H5T_STD_I32LE, H5T_NATIVE_INT, { rows + 1 }, source->outerIndexPtr());
    impl.write_dataset(
        group + "/indices", H5T_STD_I32LE, H5T_NATIVE_INT, { nnz }, source->innerIndexPtr());
    impl.write_dataset(
        group + "/data", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, { nnz }, source->valuePtr());
    const Hid type = impl.text_type("attribute 'encoding'", "csr");
    impl.write_attribute(group, "encoding", type.get(), type.get(), {}, "csr");
    set_attribute(group, "shape", std::vector<std::int64_t> { source->rows(), source->cols() });
}

void H5Writer::write_string(const std::string& path, const std::string& text)
{
    const Hid type = m_impl->text_type("dataset '" + path + "'", text);
    m_impl->write_dataset(path, type.get(), type.get(), {}, text.c_str());
}

void H5Writer::set_attribute(
    const std::string& object, const std::string& name, const std::string& value)
{
    const Hid type = m_impl->text_type("attribute '" + name + "'", value);
    m_impl->write_attribute(object, name, type.get(), type.get(), {}, value.c_str());
}

void H5Writer::set_attribute(const std::string& object, const std::string& name, const char* value)
{
    set_attribute(object, name, std::string(value ? value : ""));
}

void H5Writer::set_attribute(const std::string& object, const std::string& name, std::int64_t value)
{
    m_impl->write_attribute(object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, {}, &value);
}

void H5Writer::set_attribute(const std::string& object, const std::string& name, int value)
{
    set_attribute(object, name, std::int64_t(value));
}

void H5Writer::set_attribute(const std::string& object, const std::string& name, double value)
{
    m_impl->write_attribute(object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {}, &value);
}

void H5Writer::set_attribute(
    const std::string& object, const std::string& name, const std::vector<std::int64_t>& values)
{
    m_impl->write_attribute(
        object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, { hsize_t(values.size()) }, values.data());
}

void H5Writer::stamp_format(const std::string& name, int version)
{
    if (name.empty() || version < 1)
        throw_error("{}: invalid format stamp '{}' version {}", m_impl->target, name, version);
    set_attribute("/", "format_name", name);
    set_attribute("/", "format_version", std::int64_t(version));
}

void H5Writer::update_attribute(
    const std::string& raw_object, const std::string& name, std::int64_t value)
{
    Impl& impl = *m_impl;
    impl.check_open();
    const std::string object = h5::normalize(impl.target, raw_object);
    const Hid attribute(
        H5Aopen_by_name(impl.file.get(), object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
        H5Aclose);
    const Hid space(attribute.valid() ? H5Aget_space(attribute.get()) : -1, H5Sclose);
    if (!space.valid() || H5Sget_simple_extent_type(space.get()) != H5S_SCALAR
        || H5Awrite(attribute.get(), H5T_NATIVE_INT64, &value) < 0)
        throw_error("{}: cannot update attribute '{}' of '{}': {}", impl.target, name, object,
            h5::reason());
}

void H5Writer::flush()
{
    Impl& impl = *m_impl;
    impl.check_open();
    if (H5Fflush(impl.file.get(), H5F_SCOPE_GLOBAL) < 0)
        throw_error("{}: cannot write HDF5 file: {}", impl.target, h5::reason());
}

void H5Writer::publish()
{
    Impl& impl = *m_impl;
    flush();
    if (!impl.published)
        impl.atomic.commit();
    impl.published = true;
}

void H5Writer::commit()
{
    Impl& impl = *m_impl;
    impl.check_open();
    impl.committed = true; // no further writes, whatever happens below
    impl.series.clear(); // close the series' datasets before the file
    if (H5Fflush(impl.file.get(), H5F_SCOPE_GLOBAL) < 0)
        throw_error("{}: cannot write HDF5 file: {}", impl.target, h5::reason());
    if (!impl.file.reset())
        throw_error("{}: cannot close HDF5 file: {}", impl.target, h5::reason());
    if (!impl.published)
        impl.atomic.commit();
}

} // namespace mat
