// Series: chunked HDF5 datasets that grow by one item per append (formats/hdf5_internal.hpp).

#include <algorithm>

#include "common/error.hpp"
#include "formats/hdf5_internal.hpp"

namespace mat::h5 {

namespace {
    // Chunks of up to 64 items and about 256 KiB, so that a short run does not allocate large
    // chunks; an item above 1 MiB is split by rows so that a chunk stays near 1 MiB (HDF5's
    // default chunk cache per dataset).
    std::vector<hsize_t> series_chunk_shape(const std::vector<hsize_t>& item_dims)
    {
        constexpr hsize_t group_bytes = 256 * 1024;
        constexpr hsize_t split_bytes = 1 << 20;
        hsize_t item_bytes = sizeof(double);
        for (hsize_t d : item_dims)
            item_bytes *= d;
        std::vector<hsize_t> chunk { std::clamp<hsize_t>(group_bytes / item_bytes, 1, 64) };
        chunk.insert(chunk.end(), item_dims.begin(), item_dims.end());
        if (item_bytes > split_bytes) {
            const hsize_t row_bytes = item_bytes / item_dims[0];
            chunk[1] = std::clamp<hsize_t>(split_bytes / row_bytes, 1, item_dims[0]);
        }
        return chunk;
    }
} // namespace

Series create_series(hid_t file, hid_t dcpl, const std::string& target, const std::string& path,
    const std::vector<hsize_t>& item_dims, hsize_t capacity)
{
    std::vector<hsize_t> dims { capacity };
    dims.insert(dims.end(), item_dims.begin(), item_dims.end());
    std::vector<hsize_t> max_dims = dims;
    if (capacity == 0)
        max_dims[0] = H5S_UNLIMITED;
    const Hid space(H5Screate_simple(int(dims.size()), dims.data(), max_dims.data()), H5Sclose);
    bool layout_ok = false;
    if (capacity == 0) {
        const std::vector<hsize_t> chunk = series_chunk_shape(item_dims);
        layout_ok = H5Pset_chunk(dcpl, int(chunk.size()), chunk.data()) >= 0;
    } else {
        // Reserved: contiguous storage allocated now (the file grows sparsely, no fill is
        // written), so that writing an item changes no metadata of the file.
        layout_ok = H5Pset_layout(dcpl, H5D_CONTIGUOUS) >= 0
            && H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_EARLY) >= 0
            && H5Pset_fill_time(dcpl, H5D_FILL_TIME_NEVER) >= 0;
    }
    if (!space.valid() || !layout_ok)
        throw_error("{}: cannot create series '{}': {}", target, path, reason());
    Hid dataset(
        H5Dcreate2(file, path.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, dcpl, H5P_DEFAULT),
        H5Dclose);
    if (!dataset.valid())
        throw_error("{}: cannot create series '{}': {}", target, path, reason());
    return Series { std::move(dataset), item_dims, 0, capacity };
}

void append_to_series(Series& series, const std::string& target, const std::string& path,
    const double* data, std::int64_t rows, std::int64_t cols)
{
    const std::vector<hsize_t>& item = series.item_dims;
    const bool shape_ok = item.empty() ? rows == 1 && cols == 1
        : item.size() == 1             ? (rows == 1 || cols == 1) && hsize_t(rows * cols) == item[0]
                                       : hsize_t(rows) == item[0] && hsize_t(cols) == item[1];
    if (!shape_ok)
        throw_error("{}: cannot append to series '{}': an item of {} x {}, expected {}", target,
            path, rows, cols, describe_dims(item));

    const bool reserved = series.capacity > 0;
    if (reserved && series.size >= series.capacity)
        throw_error("{}: cannot append to series '{}': its {} reserved items are written", target,
            path, series.capacity);
    std::vector<hsize_t> dims { reserved ? series.capacity : series.size + 1 };
    dims.insert(dims.end(), item.begin(), item.end());
    std::vector<hsize_t> start(dims.size(), 0);
    start[0] = series.size;
    std::vector<hsize_t> count = dims;
    count[0] = 1;
    const hsize_t values = hsize_t(rows * cols);
    if (!reserved && H5Dset_extent(series.dataset.get(), dims.data()) < 0)
        throw_error("{}: cannot append to series '{}': {}", target, path, reason());
    const Hid file_space(H5Dget_space(series.dataset.get()), H5Sclose);
    const Hid memory_space(H5Screate_simple(1, &values, nullptr), H5Sclose);
    const bool written = file_space.valid() && memory_space.valid()
        && H5Sselect_hyperslab(
               file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr)
            >= 0
        && H5Dwrite(series.dataset.get(), H5T_NATIVE_DOUBLE, memory_space.get(), file_space.get(),
               H5P_DEFAULT, data)
            >= 0;
    if (!written) {
        const std::string why = reason();
        dims[0] = series.size; // keep the previous items only
        if (!reserved)
            H5Dset_extent(series.dataset.get(), dims.data());
        H5Eclear2(H5E_DEFAULT);
        throw_error("{}: cannot append to series '{}': {}", target, path, why);
    }
    ++series.size;
}

} // namespace mat::h5
