// VTK frames for ParaView: XML UnstructuredGrid (.vtu) triangles and collections (.pvd).
//
// Inline binary arrays follow VTK's own writer (vtkXMLWriter, no compression): the byte count
// of the data as a UInt64 (header_type="UInt64") followed by the data, base64-encoded as ONE
// stream (vtkXMLDataParser::ReadUncompressedData reads the header and then seeks past it within
// the same decoded stream, so the header must not be padded and encoded on its own).

#include <climits>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "common/error.hpp"
#include "formats/frame_io.hpp"
#include "formats/frame_io_internal.hpp"

namespace mat {

namespace {

    /// `text` with the five XML special characters escaped, for an attribute value.
    std::string xml_escape(const std::string& text)
    {
        std::string out;
        out.reserve(text.size());
        for (char c : text) {
            switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '\'':
                out += "&apos;";
                break;
            default:
                out += c;
            }
        }
        return out;
    }

    /// Appends the base64 encoding (RFC 4648, padded) of `bytes` to `out`.
    void append_base64(std::string& out, const std::string& bytes)
    {
        static constexpr char alphabet[]
            = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        const auto* in = reinterpret_cast<const unsigned char*>(bytes.data());
        const std::size_t n = bytes.size();
        const std::size_t begin = out.size();
        out.resize(begin + (n + 2) / 3 * 4);
        char* o = out.data() + begin;
        std::size_t i = 0;
        for (; i + 3 <= n; i += 3, o += 4) {
            const std::uint32_t v = (std::uint32_t(in[i]) << 16) | (std::uint32_t(in[i + 1]) << 8)
                | std::uint32_t(in[i + 2]);
            o[0] = alphabet[(v >> 18) & 63];
            o[1] = alphabet[(v >> 12) & 63];
            o[2] = alphabet[(v >> 6) & 63];
            o[3] = alphabet[v & 63];
        }
        if (i < n) {
            const bool two = i + 1 < n;
            const std::uint32_t v
                = (std::uint32_t(in[i]) << 16) | (two ? std::uint32_t(in[i + 1]) << 8 : 0u);
            o[0] = alphabet[(v >> 18) & 63];
            o[1] = alphabet[(v >> 12) & 63];
            o[2] = two ? alphabet[(v >> 6) & 63] : '=';
            o[3] = '=';
        }
    }

    template <typename T> constexpr const char* vtk_type_name()
    {
        if constexpr (std::is_same_v<T, double>)
            return "Float64";
        else if constexpr (std::is_same_v<T, std::int32_t>)
            return "Int32";
        else
            return "UInt8";
    }

    /// Writes a <DataArray> of `count` values of T, produced by `fill(put)` calling put(value)
    /// once per value in order (tuples of `components` values).
    template <typename T, typename Fill>
    void append_data_array(std::string& out, const std::string& name, int components,
        std::size_t count, VtuEncoding encoding, Fill&& fill)
    {
        fmt::format_to(
            std::back_inserter(out), "        <DataArray type=\"{}\"", vtk_type_name<T>());
        if (!name.empty())
            fmt::format_to(std::back_inserter(out), " Name=\"{}\"", xml_escape(name));
        fmt::format_to(std::back_inserter(out), " NumberOfComponents=\"{}\" format=\"{}\">\n",
            components, encoding == VtuEncoding::binary ? "binary" : "ascii");
        if (encoding == VtuEncoding::binary) {
            std::string raw;
            raw.reserve(8 + count * sizeof(T));
            detail::append_little_endian(raw, std::uint64_t(count * sizeof(T)));
            fill([&](T value) { detail::append_little_endian(raw, value); });
            out += "          ";
            append_base64(out, raw);
        } else {
            fmt::memory_buffer text;
            std::size_t written = 0;
            fill([&](T value) {
                const char* separator = written % std::size_t(components) == 0
                    ? (written == 0 ? "          " : "\n          ")
                    : " ";
                if constexpr (std::is_same_v<T, std::uint8_t>)
                    fmt::format_to(fmt::appender(text), "{}{}", separator, int(value));
                else
                    fmt::format_to(fmt::appender(text), "{}{}", separator, value);
                ++written;
            });
            out.append(text.data(), text.size());
        }
        out += "\n        </DataArray>\n";
    }

    void check_fields(
        const std::string& path, Index num_vertices, const std::vector<PointField>& fields)
    {
        std::set<std::string> names;
        for (const PointField& field : fields) {
            if (field.name.empty())
                throw_error("{}: cannot write VTU frame: a point field has an empty name", path);
            if (!names.insert(field.name).second)
                throw_error("{}: cannot write VTU frame: two point fields are named '{}'", path,
                    field.name);
            if (field.values.rows() != num_vertices
                || (field.values.cols() != 1 && field.values.cols() != 3))
                throw_error("{}: cannot write VTU frame: point field '{}' is {} x {}, expected "
                            "{} x 1 or {} x 3 (one row per vertex)",
                    path, field.name, field.values.rows(), field.values.cols(), num_vertices,
                    num_vertices);
            for (Index i = 0; i < num_vertices; ++i)
                if (!field.values.row(i).allFinite())
                    throw_error("{}: cannot write VTU frame: point field '{}' is not finite at "
                                "vertex {}",
                        path, field.name, i);
        }
    }

} // namespace

void write_vtu(const std::string& path, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3i>& faces, const std::vector<PointField>& fields,
    VtuEncoding encoding)
{
    detail::check_frame(path, "VTU frame", positions, faces);
    const Index num_vertices = positions.rows();
    const Index num_faces = faces.rows();
    if (num_faces > INT32_MAX / 3)
        throw_error("{}: cannot write VTU frame: {} faces exceed the Int32 offsets' range", path,
            num_faces);
    check_fields(path, num_vertices, fields);

    std::string out;
    out.reserve(std::size_t(num_vertices) * 40 + std::size_t(num_faces) * 20 + 1024);
    out += "<?xml version=\"1.0\"?>\n"
           "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
           "header_type=\"UInt64\">\n"
           "  <UnstructuredGrid>\n";
    fmt::format_to(std::back_inserter(out),
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n", num_vertices, num_faces);

    out += "      <PointData";
    for (const auto& [attribute, components] : { std::pair { "Scalars", 1 }, { "Vectors", 3 } })
        for (const PointField& field : fields)
            if (field.values.cols() == components) {
                fmt::format_to(
                    std::back_inserter(out), " {}=\"{}\"", attribute, xml_escape(field.name));
                break;
            }
    out += ">\n";
    for (const PointField& field : fields) {
        const MatX& values = field.values;
        append_data_array<double>(out, field.name, int(values.cols()), std::size_t(values.size()),
            encoding, [&](auto&& put) {
                for (Index i = 0; i < values.rows(); ++i)
                    for (Index k = 0; k < values.cols(); ++k)
                        put(values(i, k));
            });
    }
    out += "      </PointData>\n      <Points>\n";
    append_data_array<double>(
        out, "Points", 3, std::size_t(3 * num_vertices), encoding, [&](auto&& put) {
            for (Index i = 0; i < num_vertices; ++i)
                for (int k = 0; k < 3; ++k)
                    put(positions(i, k));
        });
    out += "      </Points>\n      <Cells>\n";
    append_data_array<std::int32_t>(
        out, "connectivity", 1, std::size_t(3 * num_faces), encoding, [&](auto&& put) {
            for (Index f = 0; f < num_faces; ++f)
                for (int k = 0; k < 3; ++k)
                    put(std::int32_t(faces(f, k)));
        });
    append_data_array<std::int32_t>(
        out, "offsets", 1, std::size_t(num_faces), encoding, [&](auto&& put) {
            for (Index f = 0; f < num_faces; ++f)
                put(std::int32_t(3 * (f + 1)));
        });
    constexpr std::uint8_t vtk_triangle = 5;
    append_data_array<std::uint8_t>(
        out, "types", 1, std::size_t(num_faces), encoding, [&](auto&& put) {
            for (Index f = 0; f < num_faces; ++f)
                put(vtk_triangle);
        });
    out += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
    detail::write_file_atomically(path, out);
}

void write_pvd(const std::string& path, const std::vector<PvdEntry>& entries)
{
    std::string out = "<?xml version=\"1.0\"?>\n"
                      "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
                      "  <Collection>\n";
    for (std::size_t i = 0; i < entries.size(); ++i) {
        const PvdEntry& entry = entries[i];
        if (!std::isfinite(entry.time))
            throw_error("{}: cannot write collection: entry {} has time {}, expected a finite "
                        "number",
                path, i, entry.time);
        if (entry.file.empty())
            throw_error("{}: cannot write collection: entry {} has no file name", path, i);
        fmt::format_to(std::back_inserter(out),
            "    <DataSet timestep=\"{}\" group=\"\" part=\"{}\" file=\"{}\"/>\n", entry.time,
            entry.part, xml_escape(entry.file));
    }
    out += "  </Collection>\n</VTKFile>\n";
    detail::write_file_atomically(path, out);
}

} // namespace mat
