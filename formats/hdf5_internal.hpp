#pragma once
// Private to formats/hdf5_*.cpp: the only header that includes HDF5. Handles that close
// themselves, path normalisation, and turning HDF5's error stack into one line for mat::Error.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <hdf5.h>

namespace mat::h5 {

/// Switches off HDF5's printing of error stacks to stderr (process-wide, once).
void silence_errors();

/// The innermost message on HDF5's current error stack ("truncated file: eof = 96, ..."),
/// or "unknown HDF5 error"; clears the stack. Call right after the failing HDF5 call.
std::string reason();

/// An HDF5 identifier closed by its close function when the handle goes.
class Hid {
public:
    using Close = herr_t (*)(hid_t);
    Hid() = default;
    Hid(hid_t id, Close close)
        : m_id(id)
        , m_close(close)
    {
    }
    ~Hid() { reset(); }
    Hid(const Hid&) = delete;
    Hid& operator=(const Hid&) = delete;
    Hid(Hid&& other) noexcept
        : m_id(std::exchange(other.m_id, H5I_INVALID_HID))
        , m_close(other.m_close)
    {
    }
    Hid& operator=(Hid&& other) noexcept
    {
        if (this != &other) {
            reset();
            m_id = std::exchange(other.m_id, H5I_INVALID_HID);
            m_close = other.m_close;
        }
        return *this;
    }

    hid_t get() const { return m_id; }
    bool valid() const { return m_id >= 0; }
    /// Closes now; returns false if the close failed.
    bool reset()
    {
        bool ok = true;
        if (m_id >= 0 && m_close)
            ok = m_close(m_id) >= 0;
        m_id = H5I_INVALID_HID;
        return ok;
    }

private:
    hid_t m_id = H5I_INVALID_HID;
    Close m_close = nullptr;
};

/// "a//b/" -> "/a/b"; "" and "/" -> "/". Throws mat::Error (naming `file`) on "." or "..".
std::string normalize(const std::string& file, const std::string& path);
/// The components of a normalised path ("/a/b" -> {"a", "b"}).
std::vector<std::string> components(const std::string& path);
/// The prefixes of a normalised path ("/a/b" -> {"/a", "/a/b"}).
std::vector<std::string> prefixes(const std::string& path);

/// What kind of object `path` (normalised) is: H5I_GROUP, H5I_DATASET, another type, or
/// H5I_BADID if there is none (also when a parent is missing).
H5I_type_t object_type(hid_t file, const std::string& path);

/// "64-bit floats", "32-bit signed integers", "text", ... for messages.
std::string describe_type(hid_t type);
/// "100 x 3", "100", "scalar".
std::string describe_dims(const std::vector<hsize_t>& dims);

/// A fixed-length, NUL-terminated UTF-8 string type for `text`.
Hid string_type(const std::string& text);
/// Reads a scalar string attribute (`is_attribute`) or dataset, fixed or variable length, into
/// `out`. Returns an empty string on success, else what went wrong (for a message).
std::string read_text(hid_t object, bool is_attribute, std::string& out);

/// A series (H5Writer::create_series) kept open by the writer for fast appends
/// (formats/hdf5_series.cpp).
struct Series {
    Hid dataset;
    std::vector<hsize_t> item_dims; ///< the shape of one item (rank 0 to 2, entries >= 1)
    hsize_t size = 0; ///< items written
    hsize_t capacity = 0; ///< items reserved (0: the dataset grows by one item per append)
};

/// Creates the series `path` (normalised; its parent exists and nothing is at `path`) in `file`
/// with the dataset creation list `dcpl` (filters set, chunks not), empty, of 64-bit floats.
/// `capacity` > 0 reserves that many items instead (H5Writer::create_series).
/// `target` names the file in errors.
Series create_series(hid_t file, hid_t dcpl, const std::string& target, const std::string& path,
    const std::vector<hsize_t>& item_dims, hsize_t capacity = 0);
/// Appends one item of `rows x cols` values (`data`, row by row) to `series` at `path`.
/// Throws mat::Error if the shape does not match or HDF5 fails; the series then keeps its
/// previous items.
void append_to_series(Series& series, const std::string& target, const std::string& path,
    const double* data, std::int64_t rows, std::int64_t cols);

} // namespace mat::h5
