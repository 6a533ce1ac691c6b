// TetGen .node/.ele reader and writer.
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

using tet_mesh_io_detail::ends_with;
using tet_mesh_io_detail::finish;
using tet_mesh_io_detail::RawTets;
using tet_mesh_io_detail::validate;

namespace {

    using text_io::quote;

    // ---- TetGen -----------------------------------------------------------------------------

    // Line-by-line reader of one TetGen file (.node or .ele).
    class TetGenFile : public text_io::LineParser {
    public:
        using LineParser::LineParser;

        // The header's integers: at least 1, at most `layout_fields`; missing ones keep their
        // defaults.
        void header(std::vector<std::int64_t>& values, const char* layout)
        {
            if (!m_reader.next())
                fail("empty file: expected the header '{}'", layout);
            const auto& tokens = m_reader.tokens();
            if (tokens.size() > values.size())
                fail("malformed header: expected at most {} values ({}), found {}", values.size(),
                    layout, tokens.size());
            for (std::size_t k = 0; k < tokens.size(); ++k)
                if (!text_io::parse_integer(tokens[k], values[k]) || values[k] < 0
                    || values[k] > INT_MAX)
                    fail("malformed header: {} is not a non-negative integer ({})",
                        quote(tokens[k]), layout);
        }

        void entry(const char* what, std::int64_t e, std::int64_t count, std::size_t values,
            const char* layout)
        {
            if (!m_reader.next())
                fail("end of file: the header declares {} {}, found {}", count, what, e);
            if (m_reader.tokens().size() != values)
                fail("wrong number of fields: expected {} ({}), found {}", values, layout,
                    m_reader.tokens().size());
        }

        void expect_end(std::int64_t count, const char* what)
        {
            if (m_reader.next())
                fail("more data after the {} {} the header declares", count, what);
        }

        std::int64_t integer_field(std::size_t k, const char* field) const
        {
            const std::string_view token = m_reader.tokens()[k];
            std::int64_t value = 0;
            if (!text_io::parse_integer(token, value))
                fail("{} {} is not an integer", field, quote(token));
            return value;
        }

        double real_field(std::size_t k, const char* field, bool finite) const
        {
            const std::string_view token = m_reader.tokens()[k];
            double value = 0.0;
            if (!text_io::parse_real(token, value))
                fail("{} {} is not a number", field, quote(token));
            if (finite && !std::isfinite(value))
                fail("{} {} is not finite", field, quote(token));
            return value;
        }
    };

    std::string tetgen_base(const std::string& path)
    {
        for (const char* ext : { ".node", ".ele" })
            if (ends_with(path, ext))
                return path.substr(0, path.size() - std::string_view(ext).size());
        return path;
    }

} // namespace

TetMesh read_tetgen_from_strings(std::string_view node_text, const std::string& node_name,
    std::string_view ele_text, const std::string& ele_name)
{
    RawTets raw;
    // .node: `#points dimension #attributes #markers`, then `id x y z [attributes] [marker]`.
    TetGenFile node(node_text, node_name);
    std::vector<std::int64_t> node_header { 0, 3, 0, 0 };
    const char* node_layout = "#points 3 #attributes #boundary-markers";
    node.header(node_header, node_layout);
    const std::int64_t num_points = node_header[0];
    if (num_points == 0)
        node.fail("0 points: points stored in a .poly file are not supported");
    if (node_header[1] != 3)
        node.fail("dimension {}: only 3D meshes are supported", node_header[1]);
    if (node_header[3] > 1)
        node.fail(
            "malformed header: the boundary-marker flag is {}, expected 0 or 1", node_header[3]);
    const std::size_t point_fields = static_cast<std::size_t>(4 + node_header[2] + node_header[3]);
    std::int64_t base = 0;
    for (std::int64_t i = 0; i < num_points; ++i) {
        node.entry("points", i, num_points, point_fields, "id x y z [attributes] [marker]");
        const std::int64_t id = node.integer_field(0, "point id");
        if (i == 0) {
            if (id != 0 && id != 1)
                node.fail("the first point id is {}: expected 0 or 1", id);
            base = id;
        } else if (id != base + i) {
            node.fail("point id {} out of sequence: expected {}", id, base + i);
        }
        for (std::size_t k = 1; k <= 3; ++k)
            raw.positions.push_back(node.real_field(k, k == 1 ? "x" : k == 2 ? "y" : "z", true));
        for (std::size_t k = 4; k < point_fields; ++k)
            node.real_field(k, "attribute or marker", false);
    }
    node.expect_end(num_points, "points");

    // .ele: `#tets nodes-per-tet #attributes`, then `id n1 ... n4|n10 [attributes]`.
    TetGenFile ele(ele_text, ele_name);
    std::vector<std::int64_t> ele_header { 0, 4, 0 };
    ele.header(ele_header, "#tets 4|10 #attributes");
    const std::int64_t num_tets = ele_header[0];
    if (ele_header[1] != 4 && ele_header[1] != 10)
        ele.fail("malformed header: {} nodes per tet, expected 4 or 10", ele_header[1]);
    const std::size_t nodes = static_cast<std::size_t>(ele_header[1]);
    const std::size_t tet_fields = static_cast<std::size_t>(1 + ele_header[1] + ele_header[2]);
    for (std::int64_t t = 0; t < num_tets; ++t) {
        ele.entry("tets", t, num_tets, tet_fields, "id n1 n2 n3 n4 [more nodes] [attributes]");
        ele.integer_field(0, "tet id");
        std::array<int, 4> tet {};
        for (std::size_t k = 1; k <= nodes; ++k) {
            const std::int64_t id = ele.integer_field(k, "node index");
            if (id < base || id >= base + num_points)
                ele.fail("node index {} out of range: {} has ids {}..{}", id, node_name, base,
                    base + num_points - 1);
            if (k > 4)
                continue;
            tet[k - 1] = static_cast<int>(id - base);
            for (std::size_t m = 0; m + 1 < k; ++m)
                if (tet[m] == tet[k - 1])
                    ele.fail("degenerate tet: node index {} is repeated", id);
        }
        for (std::size_t k = 1 + nodes; k < tet_fields; ++k)
            ele.real_field(k, "attribute", false);
        raw.tets.insert(raw.tets.end(), tet.begin(), tet.end());
    }
    ele.expect_end(num_tets, "tets");
    return finish(raw, ele_name);
}

TetMesh read_tetgen(const std::string& basename_or_node_path)
{
    const std::string base = tetgen_base(basename_or_node_path);
    const std::string node_path = base + ".node";
    const std::string ele_path = base + ".ele";
    const std::string node_text = text_io::read_file(node_path);
    const std::string ele_text = text_io::read_file(ele_path);
    return read_tetgen_from_strings(node_text, node_path, ele_text, ele_path);
}

void write_tetgen(const std::string& basename_or_path, const TetMesh& mesh)
{
    const std::string base = tetgen_base(basename_or_path);
    const std::string node_path = base + ".node";
    const std::string ele_path = base + ".ele";
    validate(mesh, node_path);
    if (mesh.num_vertices() == 0)
        throw_error("{}: cannot write: the mesh has no vertices (0 points in a .node file means "
                    "'see the .poly file')",
            node_path);
    std::string node_text, ele_text;
    auto node_sink = std::back_inserter(node_text);
    fmt::format_to(node_sink, "{} 3 0 0\n", mesh.num_vertices());
    for (Index i = 0; i < mesh.num_vertices(); ++i)
        fmt::format_to(node_sink, "{} {:.17g} {:.17g} {:.17g}\n", i, mesh.positions(i, 0),
            mesh.positions(i, 1), mesh.positions(i, 2));
    auto ele_sink = std::back_inserter(ele_text);
    fmt::format_to(ele_sink, "{} 4 0\n", mesh.num_tets());
    for (Index t = 0; t < mesh.num_tets(); ++t)
        fmt::format_to(ele_sink, "{} {} {} {} {}\n", t, mesh.tets(t, 0), mesh.tets(t, 1),
            mesh.tets(t, 2), mesh.tets(t, 3));

    // Both temporaries first, then both renames: a failure leaves neither half-written.
    AtomicFile node_file(node_path);
    AtomicFile ele_file(ele_path);
    text_io::write_file(node_file.temp_path(), node_text, node_path);
    text_io::write_file(ele_file.temp_path(), ele_text, ele_path);
    node_file.commit();
    ele_file.commit();
}

} // namespace mat
