// Shared internals of the HDF5 writer and reader (formats/hdf5_internal.hpp).

#include <mutex>

#include "common/error.hpp"
#include "formats/hdf5_internal.hpp"

namespace mat::h5 {

void silence_errors()
{
    static std::once_flag once;
    std::call_once(once, [] { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); });
}

namespace {
    herr_t take_innermost(unsigned n, const H5E_error2_t* error, void* data)
    {
        auto* out = static_cast<std::string*>(data);
        if (n == 0 && error && error->desc)
            *out = error->desc;
        return 0;
    }
} // namespace

std::string reason()
{
    std::string out;
    // Upward: the first entry is the innermost function, where the problem was detected.
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, take_innermost, &out);
    H5Eclear2(H5E_DEFAULT);
    return out.empty() ? std::string("unknown HDF5 error") : out;
}

std::string normalize(const std::string& file, const std::string& path)
{
    std::string out;
    std::size_t begin = 0;
    while (begin <= path.size()) {
        std::size_t end = path.find('/', begin);
        if (end == std::string::npos)
            end = path.size();
        const std::string part = path.substr(begin, end - begin);
        if (part == "." || part == "..")
            throw_error("{}: invalid HDF5 path '{}': '.' and '..' are not allowed", file, path);
        if (!part.empty())
            out += "/" + part;
        begin = end + 1;
    }
    return out.empty() ? std::string("/") : out;
}

std::vector<std::string> components(const std::string& path)
{
    std::vector<std::string> out;
    std::size_t begin = 1;
    while (begin < path.size()) {
        std::size_t end = path.find('/', begin);
        if (end == std::string::npos)
            end = path.size();
        out.push_back(path.substr(begin, end - begin));
        begin = end + 1;
    }
    return out;
}

std::vector<std::string> prefixes(const std::string& path)
{
    std::vector<std::string> out;
    std::string prefix;
    for (const std::string& part : components(path)) {
        prefix += "/" + part;
        out.push_back(prefix);
    }
    return out;
}

H5I_type_t object_type(hid_t file, const std::string& path)
{
    if (path == "/")
        return H5I_GROUP;
    for (const std::string& prefix : prefixes(path))
        if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) {
            H5Eclear2(H5E_DEFAULT);
            return H5I_BADID;
        }
    const Hid object(H5Oopen(file, path.c_str(), H5P_DEFAULT), H5Oclose);
    if (!object.valid()) {
        H5Eclear2(H5E_DEFAULT);
        return H5I_BADID;
    }
    return H5Iget_type(object.get());
}

std::string describe_type(hid_t type)
{
    const std::size_t bits = 8 * H5Tget_size(type);
    switch (H5Tget_class(type)) {
    case H5T_FLOAT:
        return fmt::format("{}-bit floats", bits);
    case H5T_INTEGER:
        return fmt::format(
            "{}-bit {} integers", bits, H5Tget_sign(type) == H5T_SGN_NONE ? "unsigned" : "signed");
    case H5T_STRING:
        return "text";
    case H5T_COMPOUND:
        return "compound records";
    case H5T_ENUM:
        return "enum values";
    default:
        return "non-numeric data";
    }
}

std::string describe_dims(const std::vector<hsize_t>& dims)
{
    if (dims.empty())
        return "scalar";
    std::string out;
    for (std::size_t i = 0; i < dims.size(); ++i)
        out += (i ? " x " : "") + std::to_string(dims[i]);
    return out;
}

Hid string_type(const std::string& text)
{
    Hid type(H5Tcopy(H5T_C_S1), H5Tclose);
    if (!type.valid() || H5Tset_size(type.get(), text.size() + 1) < 0
        || H5Tset_strpad(type.get(), H5T_STR_NULLTERM) < 0
        || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
        return Hid();
    return type;
}

std::string read_text(hid_t object, bool is_attribute, std::string& out)
{
    const Hid type(is_attribute ? H5Aget_type(object) : H5Dget_type(object), H5Tclose);
    const Hid space(is_attribute ? H5Aget_space(object) : H5Dget_space(object), H5Sclose);
    if (!type.valid() || !space.valid())
        return reason();
    if (H5Tget_class(type.get()) != H5T_STRING)
        return fmt::format("holds {}, expected text", describe_type(type.get()));
    if (H5Sget_simple_extent_npoints(space.get()) != 1)
        return fmt::format(
            "holds {} strings, expected one", H5Sget_simple_extent_npoints(space.get()));
    const auto read = [&](hid_t memory_type, void* buffer) {
        return is_attribute ? H5Aread(object, memory_type, buffer)
                            : H5Dread(object, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
    };
    const htri_t variable = H5Tis_variable_str(type.get());
    if (variable < 0)
        return reason();
    if (variable) {
        const Hid memory_type(H5Tcopy(H5T_C_S1), H5Tclose);
        if (!memory_type.valid() || H5Tset_size(memory_type.get(), H5T_VARIABLE) < 0
            || H5Tset_cset(memory_type.get(), H5Tget_cset(type.get())) < 0)
            return reason();
        char* text = nullptr;
        if (read(memory_type.get(), &text) < 0)
            return reason();
        out = text ? std::string(text) : std::string();
        H5free_memory(text);
        return "";
    }
    const std::size_t size = H5Tget_size(type.get());
    std::string buffer(size, '\0');
    if (size > 0 && read(type.get(), buffer.data()) < 0)
        return reason();
    // NUL-terminated or NUL-padded: the text ends at the first NUL.
    const std::size_t end = buffer.find('\0');
    out = buffer.substr(0, end);
    return "";
}

} // namespace mat::h5
