// Medit .mesh reader and writer.
#include "formats/tet_mesh_io.hpp"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <vector>

#include "common/error.hpp"
#include "formats/atomic_file.hpp"
#include "formats/tet_mesh_io_detail.hpp"
#include "formats/text_io.hpp"

namespace mat {

using tet_mesh_io_detail::finish;
using tet_mesh_io_detail::iequals;
using tet_mesh_io_detail::RawTets;
using tet_mesh_io_detail::validate;
using tet_mesh_io_detail::write_atomic;

namespace {

    using text_io::quote;

    // ---- Medit ----------------------------------------------------------------------------

    // Sections read only to be skipped: their name and the number of values per entry line.
    struct SkippedSection {
        const char* name;
        std::size_t values;
    };
    constexpr std::array<SkippedSection, 24> skipped_sections { {
        { "Edges", 3 },
        { "Triangles", 4 },
        { "Quadrilaterals", 5 },
        { "Hexahedra", 9 },
        { "Prisms", 7 },
        { "Pyramids", 6 },
        { "EdgesP2", 4 },
        { "TrianglesP2", 7 },
        { "TetrahedraP2", 11 },
        { "Corners", 1 },
        { "Ridges", 1 },
        { "RequiredVertices", 1 },
        { "RequiredEdges", 1 },
        { "RequiredTriangles", 1 },
        { "RequiredQuadrilaterals", 1 },
        { "RequiredTetrahedra", 1 },
        { "Normals", 3 },
        { "Tangents", 3 },
        { "NormalAtVertices", 2 },
        { "TangentAtVertices", 2 },
        { "TangentAtEdges", 3 },
        { "NormalAtTriangleVertices", 3 },
        { "NormalAtQuadrilateralVertices", 3 },
        { "Crack", 2 },
    } };

    bool is_keyword(std::string_view token)
    {
        for (const char* name : { "End", "Dimension", "Vertices", "Tetrahedra", "Identifier",
                 "Geometry", "MeshVersionFormatted" })
            if (iequals(token, name))
                return true;
        return std::any_of(skipped_sections.begin(), skipped_sections.end(),
            [&](const SkippedSection& s) { return iequals(token, s.name); });
    }

    class MeditParser : public text_io::LineParser {
    public:
        using LineParser::LineParser;

        TetMesh parse()
        {
            std::string_view keyword;
            if (!next_token(keyword))
                fail("empty file: expected 'MeshVersionFormatted'");
            if (!iequals(keyword, "MeshVersionFormatted"))
                fail("not a Medit mesh: expected 'MeshVersionFormatted', found {}", quote(keyword));
            const int version = read_count(keyword);
            if (version < 1 || version > 4)
                fail("unsupported MeshVersionFormatted {} (expected 1 to 4)", version);
            for (;;) {
                if (!next_token(keyword))
                    fail("missing 'End': the file ends early");
                if (iequals(keyword, "End"))
                    break;
                parse_section(keyword);
            }
            if (!m_have_vertices)
                fail("no Vertices section");
            if (!m_have_tets)
                fail("no Tetrahedra section (is this a surface mesh?)");
            const std::size_t num_vertices = m_raw.positions.size() / 3;
            for (std::size_t e = 0; e < m_raw.tets.size(); ++e) {
                // Stored 1-based; now shift to 0-based and check against the vertex count.
                int& v = m_raw.tets[e];
                if (static_cast<std::size_t>(v) > num_vertices)
                    throw_error(
                        "{}: line {}: vertex index {} out of range: the mesh has {} vertices "
                        "(valid 1..{})",
                        m_name, m_tet_lines[e / 4], v, num_vertices, num_vertices);
                --v;
            }
            return finish(m_raw, m_name);
        }

    private:
        // The next token, crossing line ends. False at the end of the text.
        bool next_token(std::string_view& token)
        {
            while (m_token >= m_reader.tokens().size()) {
                if (!m_reader.next())
                    return false;
                m_token = 0;
            }
            token = m_reader.tokens()[m_token++];
            return true;
        }

        // The integer after `keyword` (on its line or the next), last on its line.
        int read_count(std::string_view keyword)
        {
            std::string_view token;
            if (!next_token(token))
                fail("end of file: expected a number after {}", quote(keyword));
            std::int64_t value = 0;
            if (!text_io::parse_integer(token, value) || value < 0 || value > INT_MAX)
                fail("{} must be followed by a non-negative integer, found {}", quote(keyword),
                    quote(token));
            if (m_token < m_reader.tokens().size())
                fail("unexpected {} after {} {}", quote(m_reader.tokens()[m_token]), quote(keyword),
                    value);
            return static_cast<int>(value);
        }

        // Moves to entry `e` of `count` of a section: a whole line of `values` tokens.
        void next_entry(
            std::string_view section, int e, int count, std::size_t values, const char* layout)
        {
            if (!m_reader.next())
                fail("end of file in the {} section: {} of its {} entries read", section, e, count);
            const auto& tokens = m_reader.tokens();
            m_token = tokens.size();
            if (is_keyword(tokens[0]))
                fail("the {} section ends at {} after {} of its {} entries", section,
                    quote(tokens[0]), e, count);
            if (tokens.size() != values)
                fail("wrong number of fields: a {} entry needs {} values ({}), found {}", section,
                    values, layout, tokens.size());
        }

        void parse_section(std::string_view keyword)
        {
            if (iequals(keyword, "Dimension")) {
                const int dimension = read_count(keyword);
                if (dimension != 3)
                    fail("Dimension {}: only 3D meshes are supported", dimension);
                m_have_dimension = true;
            } else if (iequals(keyword, "Vertices")) {
                if (!m_have_dimension)
                    fail("Vertices before 'Dimension 3'");
                if (m_have_vertices)
                    fail("a second Vertices section");
                m_have_vertices = true;
                const int count = read_count(keyword);
                for (int e = 0; e < count; ++e) {
                    next_entry("Vertices", e, count, 4, "x y z ref");
                    for (std::size_t k = 0; k < 3; ++k)
                        m_raw.positions.push_back(real_field(k, k == 0 ? "x" : k == 1 ? "y" : "z"));
                    real_field(3, "ref");
                }
            } else if (iequals(keyword, "Tetrahedra")) {
                if (m_have_tets)
                    fail("a second Tetrahedra section");
                m_have_tets = true;
                const int count = read_count(keyword);
                for (int e = 0; e < count; ++e) {
                    next_entry("Tetrahedra", e, count, 5, "i j k l ref, 1-based");
                    std::array<int, 4> tet {};
                    for (std::size_t k = 0; k < 4; ++k) {
                        const std::string_view token = m_reader.tokens()[k];
                        std::int64_t value = 0;
                        if (!text_io::parse_integer(token, value))
                            fail("vertex index {} is not an integer", quote(token));
                        if (value < 1 || value > INT_MAX)
                            fail("vertex index {} out of range: Medit indices start at 1", value);
                        tet[k] = static_cast<int>(value);
                        for (std::size_t m = 0; m < k; ++m)
                            if (tet[m] == tet[k])
                                fail("degenerate tet: vertex index {} is repeated", tet[k]);
                    }
                    real_field(4, "ref");
                    m_raw.tets.insert(m_raw.tets.end(), tet.begin(), tet.end());
                    m_tet_lines.push_back(m_reader.line_number());
                }
            } else if (iequals(keyword, "Identifier") || iequals(keyword, "Geometry")) {
                // A string (possibly quoted, with spaces): the rest of the line, or the next line.
                if (m_token < m_reader.tokens().size())
                    m_token = m_reader.tokens().size();
                else if (!m_reader.next())
                    fail("end of file: expected a value after {}", quote(keyword));
                else
                    m_token = m_reader.tokens().size();
            } else {
                const auto it = std::find_if(skipped_sections.begin(), skipped_sections.end(),
                    [&](const SkippedSection& s) { return iequals(keyword, s.name); });
                if (it == skipped_sections.end())
                    fail("unknown keyword {}", quote(keyword));
                const int count = read_count(keyword);
                for (int e = 0; e < count; ++e) {
                    next_entry(it->name, e, count, it->values, "as the Medit format defines");
                    for (std::size_t k = 0; k < it->values; ++k)
                        real_field(k, "value");
                }
            }
        }

        std::size_t m_token = 0; // next token of the current line
        bool m_have_dimension = false;
        bool m_have_vertices = false;
        bool m_have_tets = false;
        RawTets m_raw;
        std::vector<int> m_tet_lines;
    };

    std::string format_medit(const TetMesh& mesh)
    {
        std::string out;
        auto sink = std::back_inserter(out);
        fmt::format_to(
            sink, "MeshVersionFormatted 2\nDimension 3\nVertices\n{}\n", mesh.num_vertices());
        for (Index i = 0; i < mesh.num_vertices(); ++i)
            fmt::format_to(sink, "{:.17g} {:.17g} {:.17g} 0\n", mesh.positions(i, 0),
                mesh.positions(i, 1), mesh.positions(i, 2));
        fmt::format_to(sink, "Tetrahedra\n{}\n", mesh.num_tets());
        for (Index t = 0; t < mesh.num_tets(); ++t)
            fmt::format_to(sink, "{} {} {} {} 0\n", mesh.tets(t, 0) + 1, mesh.tets(t, 1) + 1,
                mesh.tets(t, 2) + 1, mesh.tets(t, 3) + 1);
        out += "End\n";
        return out;
    }

} // namespace

TetMesh read_medit_from_string(std::string_view text, const std::string& name)
{
    return MeditParser(text, name).parse();
}

TetMesh read_medit(const std::string& path)
{
    return read_medit_from_string(text_io::read_file(path), path);
}

void write_medit(const std::string& path, const TetMesh& mesh)
{
    validate(mesh, path);
    write_atomic(path, format_medit(mesh));
}

} // namespace mat
