#include "formats/medial_io.hpp"

#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/atomic_file.hpp"
#include "formats/text_io.hpp"

namespace mat {

namespace {

    using text_io::quote;

    // An unordered index pair as one 64-bit key.
    std::uint64_t pair_key(int a, int b)
    {
        if (a > b)
            std::swap(a, b);
        return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32)
            | static_cast<std::uint32_t>(b);
    }

    // An unordered index triple, sorted.
    using TripleKey = std::array<int, 3>;
    TripleKey triple_key(int a, int b, int c)
    {
        TripleKey key { a, b, c };
        if (key[0] > key[1])
            std::swap(key[0], key[1]);
        if (key[1] > key[2])
            std::swap(key[1], key[2]);
        if (key[0] > key[1])
            std::swap(key[0], key[1]);
        return key;
    }
    struct TripleHash {
        std::size_t operator()(const TripleKey& key) const
        {
            std::uint64_t h = 1469598103934665603ull;
            for (int v : key)
                h = (h ^ static_cast<std::uint32_t>(v)) * 1099511628211ull;
            return static_cast<std::size_t>(h);
        }
    };

    const char* header_text = "'nv ne nf' (Q-MAT) or 'nv nc ns' (paper)";

    bool is_record_letter(std::string_view token)
    {
        return token.size() == 1
            && (token[0] == 'v' || token[0] == 'e' || token[0] == 'f' || token[0] == 'c'
                || token[0] == 's');
    }

    const char* primitive_name(char letter)
    {
        switch (letter) {
        case 'e':
            return "edge";
        case 'f':
            return "face";
        case 'c':
            return "cone";
        default:
            return "slab";
        }
    }

    // Reads the body of a .ma text line by line; every failure names the file and the line.
    class MedialParser : public text_io::LineParser {
    public:
        using LineParser::LineParser;

        MedialMesh parse()
        {
            parse_header();
            while (m_reader.next())
                parse_record();
            check_counts();
            return build_mesh();
        }

    private:
        void parse_header()
        {
            if (!m_reader.next())
                fail("missing header {}: the file has no data", header_text);
            const auto& tokens = m_reader.tokens();
            if (is_record_letter(tokens[0]))
                fail("missing header: expected the counts {} before the first record", header_text);
            if (tokens.size() != 3)
                fail("malformed header: expected 3 counts {}, found {} fields", header_text,
                    tokens.size());
            for (std::size_t k = 0; k < 3; ++k) {
                std::int64_t value = 0;
                if (!text_io::parse_integer(tokens[k], value) || value < 0 || value > INT_MAX)
                    fail("malformed header: count {} is not a non-negative integer {}",
                        quote(tokens[k]), header_text);
                m_counts[k] = static_cast<int>(value);
            }
            m_header_line = m_reader.line_number();
        }

        void expect_fields(char letter, std::size_t values, const char* layout) const
        {
            const std::size_t found = m_reader.tokens().size() - 1;
            if (found != values)
                fail("wrong number of fields: '{}' records have {} values ({}), found {}", letter,
                    values, layout, found);
        }

        int index_field(std::size_t k) const
        {
            const std::string_view token = m_reader.tokens()[k];
            std::int64_t value = 0;
            if (!text_io::parse_integer(token, value))
                fail("index {} is not an integer", quote(token));
            if (value < 0 || value >= m_counts[0]) {
                if (m_counts[0] == 0)
                    fail("index {} out of range: the header declares no vertices", value);
                fail("index {} out of range: the header declares {} vertices (valid 0..{})", value,
                    m_counts[0], m_counts[0] - 1);
            }
            return static_cast<int>(value);
        }

        /// `v x y z r`, or Medial IPC's `.mat` layout `v x y z r t` with the tet node `t` of
        /// the sphere (an integer, not used: docs/mat-bake.md). Every `v` of a file has the
        /// same layout; a `.mat` file is of the cones/slabs dialect.
        void check_sphere_fields()
        {
            const std::size_t found = m_reader.tokens().size() - 1;
            if (m_sphere_fields == 0 && (found == 4 || found == 5)) {
                m_sphere_fields = found;
                m_sphere_fields_line = m_reader.line_number();
                if (found == 5)
                    note_dialect(MedialDialect::paper, 'v');
            }
            if (m_sphere_fields == 0 || found != m_sphere_fields) {
                if (m_sphere_fields == 5)
                    fail("wrong number of fields: 'v' records have 5 values (v x y z r tet-node) "
                         "since line {}, found {}",
                        m_sphere_fields_line, found);
                expect_fields('v', 4, "v x y z r");
            }
            if (found == 5) {
                std::int64_t node = 0;
                if (!text_io::parse_integer(m_reader.tokens()[5], node))
                    fail("tet node {} of vertex {} is not an integer", quote(m_reader.tokens()[5]),
                        m_radii.size());
            }
        }

        void note_dialect(MedialDialect dialect, char letter)
        {
            if (!m_dialect) {
                m_dialect = dialect;
                m_dialect_letter = letter;
                m_dialect_line = m_reader.line_number();
            } else if (*m_dialect != dialect) {
                if (m_dialect_letter == 'v')
                    fail("'{}' record (Q-MAT dialect) in a .mat file (5-value 'v' records from "
                         "line {}): .mat files use the cones/slabs dialect (c, s)",
                        letter, m_dialect_line);
                fail("'{}' record ({} dialect) after the '{}' record of line {} ({} dialect): the "
                     "dialects cannot be mixed",
                    letter, dialect == MedialDialect::qmat ? "Q-MAT" : "paper", m_dialect_letter,
                    m_dialect_line, *m_dialect == MedialDialect::qmat ? "Q-MAT" : "paper");
            }
        }

        void parse_record()
        {
            const std::string_view letter = m_reader.tokens()[0];
            if (!is_record_letter(letter))
                fail("unknown record {}: expected v, e, f (Q-MAT) or v, c, s (paper)",
                    quote(letter));
            const char c = letter[0];
            if (c == 'v') {
                check_sphere_fields();
                const double x = real_field(1, "x");
                const double y = real_field(2, "y");
                const double z = real_field(3, "z");
                const double r = real_field(4, "r");
                if (!(r > 0.0))
                    fail("radius {} of vertex {} must be > 0", r, m_radii.size());
                m_centers.insert(m_centers.end(), { x, y, z });
                m_radii.push_back(r);
            } else if (c == 'e' || c == 'c') {
                note_dialect(c == 'e' ? MedialDialect::qmat : MedialDialect::paper, c);
                expect_fields(c, 2, c == 'e' ? "e i j" : "c i j");
                const int i = index_field(1);
                const int j = index_field(2);
                if (i == j)
                    fail("degenerate {} {} {}: vertex index {} is repeated", primitive_name(c), i,
                        j, i);
                const auto [it, inserted]
                    = m_pair_lines.emplace(pair_key(i, j), m_reader.line_number());
                if (!inserted)
                    fail("duplicate {} {} {}: same vertices as line {}", primitive_name(c), i, j,
                        it->second);
                m_pairs.insert(m_pairs.end(), { i, j });
            } else {
                note_dialect(c == 'f' ? MedialDialect::qmat : MedialDialect::paper, c);
                expect_fields(c, 3, c == 'f' ? "f i j k" : "s i j k");
                const int i = index_field(1);
                const int j = index_field(2);
                const int k = index_field(3);
                if (i == j || j == k || i == k)
                    fail("degenerate {} {} {} {}: vertex index {} is repeated", primitive_name(c),
                        i, j, k, i == j || i == k ? i : j);
                const auto [it, inserted]
                    = m_triple_lines.emplace(triple_key(i, j, k), m_reader.line_number());
                if (!inserted)
                    fail("duplicate {} {} {} {}: same vertices as line {}", primitive_name(c), i, j,
                        k, it->second);
                m_triples.insert(m_triples.end(), { i, j, k });
            }
        }

        void check_counts() const
        {
            const bool qmat = m_dialect == MedialDialect::qmat;
            const bool paper = m_dialect == MedialDialect::paper;
            const std::array<std::size_t, 3> found { m_radii.size(), m_pairs.size() / 2,
                m_triples.size() / 3 };
            const std::array<const char*, 3> names { "vertices",
                qmat ? "edges" : (paper ? "cones" : "edges (cones)"),
                qmat ? "faces" : (paper ? "slabs" : "faces (slabs)") };
            for (std::size_t k = 0; k < 3; ++k)
                if (found[k] != static_cast<std::size_t>(m_counts[k]))
                    throw_error("{}: line {}: header expects {} {}, found {}", m_name,
                        m_header_line, m_counts[k], names[k], found[k]);
        }

        MedialMesh build_mesh() const
        {
            MedialMesh mesh;
            const Index num_spheres = static_cast<Index>(m_radii.size());
            mesh.centers = Eigen::Map<const MatX3>(m_centers.data(), num_spheres, 3);
            mesh.radii = Eigen::Map<const VecX>(m_radii.data(), num_spheres);
            const Index num_triples = static_cast<Index>(m_triples.size() / 3);
            mesh.slabs = Eigen::Map<const MatX3i>(m_triples.data(), num_triples, 3);
            if (m_dialect != MedialDialect::qmat) {
                mesh.cones = Eigen::Map<const MatX2i>(
                    m_pairs.data(), static_cast<Index>(m_pairs.size() / 2), 2);
                return mesh;
            }
            // Q-MAT: the edge list repeats the faces' edges; cones are the edges on no face.
            std::unordered_set<std::uint64_t> face_edges;
            for (std::size_t t = 0; t < m_triples.size(); t += 3)
                for (int k = 0; k < 3; ++k)
                    face_edges.insert(pair_key(m_triples[t + k], m_triples[t + (k + 1) % 3]));
            std::vector<int> cones;
            for (std::size_t e = 0; e < m_pairs.size(); e += 2)
                if (face_edges.count(pair_key(m_pairs[e], m_pairs[e + 1])) == 0)
                    cones.insert(cones.end(), { m_pairs[e], m_pairs[e + 1] });
            mesh.cones
                = Eigen::Map<const MatX2i>(cones.data(), static_cast<Index>(cones.size() / 2), 2);
            return mesh;
        }

    public:
        /// True once the file has read as Medial IPC's .mat layout (5-value `v` records).
        bool has_tet_nodes() const { return m_sphere_fields == 5; }

    private:
        std::array<int, 3> m_counts { 0, 0, 0 };
        std::size_t m_sphere_fields = 0; // values of the first 'v' record (4 or 5), 0 before it
        int m_sphere_fields_line = 0;
        int m_header_line = 0;
        std::optional<MedialDialect> m_dialect;
        char m_dialect_letter = 0;
        int m_dialect_line = 0;
        std::vector<double> m_centers; // x0 y0 z0 x1 ...
        std::vector<double> m_radii;
        std::vector<int> m_pairs; // i0 j0 i1 j1 ...
        std::vector<int> m_triples; // i0 j0 k0 ...
        std::unordered_map<std::uint64_t, int> m_pair_lines; // first line of each index pair
        std::unordered_map<TripleKey, int, TripleHash> m_triple_lines;
    };

    // The reader's rules, applied to a mesh about to be written.
    void validate(const MedialMesh& mesh, const std::string& name)
    {
        const Index n = mesh.num_spheres();
        if (mesh.radii.size() != n)
            throw_error(
                "{}: cannot write: {} sphere centers but {} radii", name, n, mesh.radii.size());
        for (Index i = 0; i < n; ++i) {
            if (!mesh.centers.row(i).allFinite())
                throw_error("{}: cannot write: sphere {} has a non-finite center", name, i);
            if (!std::isfinite(mesh.radii[i]) || !(mesh.radii[i] > 0.0))
                throw_error("{}: cannot write: sphere {} has radius {} (must be finite and > 0)",
                    name, i, mesh.radii[i]);
        }
        auto check_index = [&](const char* what, Index p, int index) {
            if (index < 0 || index >= n)
                throw_error("{}: cannot write: {} {} has sphere index {} out of range (#S = {})",
                    name, what, p, index, n);
        };
        std::unordered_set<std::uint64_t> pairs;
        for (Index p = 0; p < mesh.num_cones(); ++p) {
            const int i = mesh.cones(p, 0), j = mesh.cones(p, 1);
            check_index("cone", p, i);
            check_index("cone", p, j);
            if (i == j)
                throw_error("{}: cannot write: cone {} is degenerate ({} {})", name, p, i, j);
            if (!pairs.insert(pair_key(i, j)).second)
                throw_error("{}: cannot write: cone {} ({} {}) is a duplicate", name, p, i, j);
        }
        std::unordered_set<TripleKey, TripleHash> triples;
        for (Index p = 0; p < mesh.num_slabs(); ++p) {
            const int i = mesh.slabs(p, 0), j = mesh.slabs(p, 1), k = mesh.slabs(p, 2);
            check_index("slab", p, i);
            check_index("slab", p, j);
            check_index("slab", p, k);
            if (i == j || j == k || i == k)
                throw_error("{}: cannot write: slab {} is degenerate ({} {} {})", name, p, i, j, k);
            if (!triples.insert(triple_key(i, j, k)).second)
                throw_error(
                    "{}: cannot write: slab {} ({} {} {}) is a duplicate", name, p, i, j, k);
        }
    }

    std::string format_checked(
        const MedialMesh& mesh, MedialDialect dialect, const std::string& name)
    {
        validate(mesh, name);
        // Q-MAT edge list: the cones, then every slab edge not listed yet.
        std::vector<std::array<int, 2>> edges;
        edges.reserve(static_cast<std::size_t>(mesh.num_cones() + 3 * mesh.num_slabs()));
        for (Index p = 0; p < mesh.num_cones(); ++p)
            edges.push_back({ mesh.cones(p, 0), mesh.cones(p, 1) });
        if (dialect == MedialDialect::qmat) {
            std::unordered_set<std::uint64_t> listed;
            for (const auto& e : edges)
                listed.insert(pair_key(e[0], e[1]));
            std::unordered_set<std::uint64_t> slab_edges;
            for (Index p = 0; p < mesh.num_slabs(); ++p)
                for (int k = 0; k < 3; ++k) {
                    const int a = mesh.slabs(p, k), b = mesh.slabs(p, (k + 1) % 3);
                    slab_edges.insert(pair_key(a, b));
                    if (listed.insert(pair_key(a, b)).second)
                        edges.push_back({ a, b });
                }
            Index implied = 0;
            for (Index p = 0; p < mesh.num_cones(); ++p)
                implied += slab_edges.count(pair_key(mesh.cones(p, 0), mesh.cones(p, 1)));
            if (implied > 0)
                logger().warn("{}: {} cone(s) lie on slab edges; Q-MAT cannot tell them from "
                              "the slab edges, so they will read back as part of the slabs",
                    name, implied);
        }

        std::string out;
        auto sink = std::back_inserter(out);
        fmt::format_to(sink, "{} {} {}\n", mesh.num_spheres(), edges.size(), mesh.num_slabs());
        for (Index i = 0; i < mesh.num_spheres(); ++i)
            fmt::format_to(sink, "v {:.17g} {:.17g} {:.17g} {:.17g}\n", mesh.centers(i, 0),
                mesh.centers(i, 1), mesh.centers(i, 2), mesh.radii[i]);
        const char edge_letter = dialect == MedialDialect::qmat ? 'e' : 'c';
        for (const auto& e : edges)
            fmt::format_to(sink, "{} {} {}\n", edge_letter, e[0], e[1]);
        const char face_letter = dialect == MedialDialect::qmat ? 'f' : 's';
        for (Index p = 0; p < mesh.num_slabs(); ++p)
            fmt::format_to(sink, "{} {} {} {}\n", face_letter, mesh.slabs(p, 0), mesh.slabs(p, 1),
                mesh.slabs(p, 2));
        return out;
    }

} // namespace

MedialMesh read_medial_from_string(std::string_view text, const std::string& name)
{
    MedialParser parser(text, name);
    MedialMesh mesh = parser.parse();
    if (parser.has_tet_nodes())
        logger().info("{}: Medial IPC .mat layout: the cones/slabs dialect, the fifth value of "
                      "each 'v' record (its tet node) is ignored",
            name);
    return mesh;
}

MedialMesh read_medial(const std::string& path)
{
    const std::string text = text_io::read_file(path);
    MedialMesh mesh = read_medial_from_string(text, path);
    logger().debug("{}: read {} spheres, {} cones, {} slabs", path, mesh.num_spheres(),
        mesh.num_cones(), mesh.num_slabs());
    return mesh;
}

std::string format_medial(const MedialMesh& mesh, MedialDialect dialect)
{
    return format_checked(mesh, dialect, "medial mesh");
}

void write_medial(const std::string& path, const MedialMesh& mesh, MedialDialect dialect)
{
    const std::string text = format_checked(mesh, dialect, path);
    AtomicFile file(path);
    text_io::write_file(file.temp_path(), text, path);
    file.commit();
}

} // namespace mat
