#include "formats/surface_ply.hpp"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <vector>

#include "common/error.hpp"

namespace mat::detail {

namespace {

    enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };
    enum class PlyType { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

    struct PlyProperty {
        std::string name;
        bool is_list = false;
        PlyType count_type = PlyType::uint8; ///< lists only
        PlyType type = PlyType::float32; ///< the value, or the list items
    };

    struct PlyElement {
        std::string name;
        Index count = 0;
        std::vector<PlyProperty> properties;
    };

    struct PlyHeader {
        PlyFormat format = PlyFormat::ascii;
        std::vector<PlyElement> elements;
        std::size_t body = 0; ///< byte offset of the first byte after "end_header\n"
    };

    bool parse_type(const std::string& word, PlyType& type)
    {
        static const std::pair<const char*, PlyType> names[] = { { "char", PlyType::int8 },
            { "int8", PlyType::int8 }, { "uchar", PlyType::uint8 }, { "uint8", PlyType::uint8 },
            { "short", PlyType::int16 }, { "int16", PlyType::int16 }, { "ushort", PlyType::uint16 },
            { "uint16", PlyType::uint16 }, { "int", PlyType::int32 }, { "int32", PlyType::int32 },
            { "uint", PlyType::uint32 }, { "uint32", PlyType::uint32 },
            { "float", PlyType::float32 }, { "float32", PlyType::float32 },
            { "double", PlyType::float64 }, { "float64", PlyType::float64 } };
        for (const auto& [name, value] : names)
            if (word == name) {
                type = value;
                return true;
            }
        return false;
    }

    std::size_t type_size(PlyType type)
    {
        switch (type) {
        case PlyType::int8:
        case PlyType::uint8:
            return 1;
        case PlyType::int16:
        case PlyType::uint16:
            return 2;
        case PlyType::int32:
        case PlyType::uint32:
        case PlyType::float32:
            return 4;
        case PlyType::float64:
            return 8;
        }
        return 8;
    }

    PlyHeader parse_header(const std::vector<char>& bytes, const std::string& path)
    {
        PlyHeader header;
        std::size_t pos = 0;
        int line_number = 0;
        bool has_format = false;
        while (true) {
            if (pos >= bytes.size())
                throw_error(
                    "{}: line {}: PLY header ends without 'end_header'", path, line_number + 1);
            std::size_t end = pos;
            while (end < bytes.size() && bytes[end] != '\n')
                ++end;
            std::string line(bytes.begin() + pos, bytes.begin() + end);
            pos = end + 1;
            ++line_number;
            if (!line.empty() && line.back() == '\r')
                line.pop_back();
            std::istringstream words(line);
            std::string keyword;
            words >> keyword;
            if (end >= bytes.size() && keyword != "end_header")
                throw_error("{}: line {}: PLY header ends without 'end_header'", path, line_number);
            if (line_number == 1) {
                if (line != "ply")
                    throw_error("{}: line 1: not a PLY file (expected 'ply')", path);
                continue;
            }
            if (keyword.empty() || keyword == "comment" || keyword == "obj_info")
                continue;
            if (keyword == "end_header") {
                if (!has_format)
                    throw_error("{}: line {}: PLY header has no 'format' line", path, line_number);
                header.body = std::min(pos, bytes.size());
                return header;
            }
            if (keyword == "format") {
                std::string format;
                words >> format;
                if (format == "ascii")
                    header.format = PlyFormat::ascii;
                else if (format == "binary_little_endian")
                    header.format = PlyFormat::binary_little_endian;
                else if (format == "binary_big_endian")
                    header.format = PlyFormat::binary_big_endian;
                else
                    throw_error("{}: line {}: unknown PLY format '{}'", path, line_number, format);
                has_format = true;
            } else if (keyword == "element") {
                PlyElement element;
                long long count = -1;
                std::string extra;
                if (!(words >> element.name >> count) || count < 0 || (words >> extra))
                    throw_error(
                        "{}: line {}: expected 'element <name> <count>'", path, line_number);
                element.count = static_cast<Index>(count);
                header.elements.push_back(element);
            } else if (keyword == "property") {
                if (header.elements.empty())
                    throw_error("{}: line {}: property before any element", path, line_number);
                PlyProperty property;
                std::string type;
                words >> type;
                if (type == "list") {
                    std::string count_type, item_type;
                    words >> count_type >> item_type;
                    property.is_list = true;
                    if (!parse_type(count_type, property.count_type)
                        || !parse_type(item_type, property.type))
                        throw_error("{}: line {}: bad list types '{} {}'", path, line_number,
                            count_type, item_type);
                } else if (!parse_type(type, property.type)) {
                    throw_error("{}: line {}: unknown property type '{}'", path, line_number, type);
                }
                if (!(words >> property.name))
                    throw_error("{}: line {}: property without a name", path, line_number);
                header.elements.back().properties.push_back(property);
            } else {
                throw_error("{}: line {}: unknown PLY header keyword '{}'", path, line_number,
                    keyword.substr(0, 40));
            }
        }
    }

    /// Reads the body's values one at a time, in ascii or binary, with bounds checks.
    class PlyBody {
    public:
        PlyBody(const std::vector<char>& bytes, const PlyHeader& header, const std::string& path)
            : m_bytes(bytes)
            , m_pos(header.body)
            , m_format(header.format)
            , m_path(path)
        {
        }

        /// Where errors point: the element being read and its index.
        void locate(const std::string& element, Index index)
        {
            m_element = &element;
            m_index = index;
        }

        std::size_t remaining() const { return m_bytes.size() - m_pos; }

        double value(PlyType type) { return m_format == PlyFormat::ascii ? text() : binary(type); }

        /// A list length or an index: an integer in [0, max].
        Index integer(PlyType type, Index max, const char* what)
        {
            const double v = value(type);
            if (!(v >= 0.0 && v <= static_cast<double>(max)) || v != std::floor(v))
                fail(fmt::format("{} {} is not an integer in [0, {}]", what, v, max));
            return static_cast<Index>(v);
        }

        [[noreturn]] void fail(const std::string& problem) const
        {
            throw_error(
                "{}: element {} {}: {}", m_path, m_element ? *m_element : "?", m_index, problem);
        }

    private:
        double text()
        {
            while (
                m_pos < m_bytes.size() && std::isspace(static_cast<unsigned char>(m_bytes[m_pos])))
                ++m_pos;
            std::size_t end = m_pos;
            while (end < m_bytes.size() && !std::isspace(static_cast<unsigned char>(m_bytes[end])))
                ++end;
            if (end == m_pos)
                fail("unexpected end of file");
            const std::string token(m_bytes.begin() + m_pos, m_bytes.begin() + end);
            m_pos = end;
            char* stop = nullptr;
            const double v = std::strtod(token.c_str(), &stop);
            if (stop != token.c_str() + token.size())
                fail(fmt::format("'{}' is not a number", token.substr(0, 40)));
            return v;
        }

        double binary(PlyType type)
        {
            const std::size_t n = type_size(type);
            if (remaining() < n)
                fail("unexpected end of file");
            std::uint64_t bits = 0;
            for (std::size_t i = 0; i < n; ++i) {
                const std::size_t k = m_format == PlyFormat::binary_little_endian ? i : n - 1 - i;
                bits |= std::uint64_t(static_cast<unsigned char>(m_bytes[m_pos + k])) << (8 * i);
            }
            m_pos += n;
            switch (type) {
            case PlyType::int8:
                return static_cast<std::int8_t>(bits);
            case PlyType::uint8:
                return static_cast<std::uint8_t>(bits);
            case PlyType::int16:
                return static_cast<std::int16_t>(bits);
            case PlyType::uint16:
                return static_cast<std::uint16_t>(bits);
            case PlyType::int32:
                return static_cast<std::int32_t>(bits);
            case PlyType::uint32:
                return static_cast<std::uint32_t>(bits);
            case PlyType::float32: {
                const std::uint32_t b32 = static_cast<std::uint32_t>(bits);
                float f;
                std::memcpy(&f, &b32, sizeof f);
                return f;
            }
            case PlyType::float64: {
                double d;
                std::memcpy(&d, &bits, sizeof d);
                return d;
            }
            }
            return 0.0;
        }

        const std::vector<char>& m_bytes;
        std::size_t m_pos;
        PlyFormat m_format;
        const std::string& m_path;
        const std::string* m_element = nullptr;
        Index m_index = 0;
    };

    int find_property(const PlyElement& element, std::initializer_list<const char*> names)
    {
        for (std::size_t i = 0; i < element.properties.size(); ++i)
            for (const char* name : names)
                if (element.properties[i].name == name)
                    return static_cast<int>(i);
        return -1;
    }

} // namespace

bool has_ply_magic(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    char magic[4] = {};
    in.read(magic, 4);
    return in.gcount() == 4 && std::memcmp(magic, "ply", 3) == 0
        && (magic[3] == '\n' || magic[3] == '\r');
}

RawSurface read_ply(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw_error("{}: cannot read surface: cannot open the file", path);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
    const PlyHeader header = parse_header(bytes, path);
    PlyBody body(bytes, header, path);

    RawSurface raw;
    // Polygons, flat: checked against #V once every element is read.
    std::vector<Index> polygon_indices;
    std::vector<std::size_t> polygon_starts;
    const Index max_index = std::numeric_limits<int>::max();
    for (const PlyElement& element : header.elements) {
        const bool is_vertex = element.name == "vertex";
        const bool is_face = element.name == "face";
        int xyz[3] = { -1, -1, -1 };
        int indices = -1;
        if (is_vertex) {
            xyz[0] = find_property(element, { "x" });
            xyz[1] = find_property(element, { "y" });
            xyz[2] = find_property(element, { "z" });
            for (int d = 0; d < 3; ++d)
                if (xyz[d] < 0 || element.properties[xyz[d]].is_list)
                    throw_error("{}: element vertex has no scalar property '{}'", path, "xyz"[d]);
            if (element.count > max_index)
                throw_error("{}: element vertex: {} vertices exceed the supported {}", path,
                    element.count, max_index);
        }
        if (is_face) {
            indices = find_property(element, { "vertex_indices", "vertex_index" });
            if (indices < 0 || !element.properties[indices].is_list)
                throw_error("{}: element face has no list property 'vertex_indices'", path);
        }
        // Every element takes at least one byte per value: a count beyond the file is a lie.
        if (element.count > static_cast<Index>(body.remaining()))
            throw_error("{}: element {}: {} elements cannot fit in the {} bytes left", path,
                element.name, element.count, body.remaining());
        if (is_vertex)
            raw.positions.reserve(element.count);
        for (Index e = 0; e < element.count; ++e) {
            body.locate(element.name, e);
            Vec3 position = Vec3::Zero();
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const PlyProperty& property = element.properties[p];
                if (!property.is_list) {
                    const double v = body.value(property.type);
                    for (int d = 0; d < 3; ++d)
                        if (static_cast<int>(p) == xyz[d])
                            position[d] = v;
                    continue;
                }
                const Index n = body.integer(
                    property.count_type, static_cast<Index>(body.remaining()), "list length");
                if (static_cast<int>(p) != indices) {
                    for (Index i = 0; i < n; ++i)
                        body.value(property.type);
                    continue;
                }
                polygon_starts.push_back(polygon_indices.size());
                for (Index i = 0; i < n; ++i)
                    polygon_indices.push_back(
                        body.integer(property.type, max_index, "vertex index"));
            }
            if (is_vertex)
                raw.positions.push_back(position);
        }
    }

    const Index num_vertices = static_cast<Index>(raw.positions.size());
    polygon_starts.push_back(polygon_indices.size());
    for (std::size_t f = 0; f + 1 < polygon_starts.size(); ++f) {
        const Index* polygon = polygon_indices.data() + polygon_starts[f];
        const std::size_t n = polygon_starts[f + 1] - polygon_starts[f];
        for (std::size_t k = 0; k < n; ++k)
            if (polygon[k] >= num_vertices)
                throw_error("{}: element face {}: vertex index {} out of range (there are {} "
                            "vertices)",
                    path, f, polygon[k], num_vertices);
        if (n == 1)
            ++raw.dropped_points;
        else if (n == 2)
            ++raw.dropped_lines;
        else if (n == 0)
            ++raw.dropped_polygons;
        for (std::size_t k = 1; k + 1 < n; ++k)
            raw.faces.push_back({ polygon[0], polygon[k], polygon[k + 1] });
    }
    return raw;
}

} // namespace mat::detail
