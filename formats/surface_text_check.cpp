#include "formats/surface_text_check.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "formats/surface_io_internal.hpp"
#include "formats/text_io.hpp"

namespace mat::detail {

namespace {

    using text_io::quote;

    /// The keywords of a text OFF whose vertex lines start with x y z: [ST][C][N]OFF.
    bool is_plain_off_keyword(std::string_view token)
    {
        std::size_t i = 0;
        if (token.substr(0, 2) == "ST")
            i = 2;
        if (i < token.size() && token[i] == 'C')
            ++i;
        if (i < token.size() && token[i] == 'N')
            ++i;
        return token.substr(i) == "OFF";
    }

    bool ends_with_off(std::string_view token)
    {
        return token.size() >= 3 && token.substr(token.size() - 3) == "OFF";
    }

    /// The maximum polygon size of assimp 5.2's OFF loader (it drops larger faces).
    constexpr std::int64_t max_face_size = 9;

    class OffChecker : public text_io::LineParser {
    public:
        using LineParser::LineParser;

        void check()
        {
            if (!m_reader.next())
                return; // an empty file: assimp says so
            const std::string_view first = m_reader.tokens()[0];
            std::size_t k = 0;
            if (is_plain_off_keyword(first)) {
                if (m_reader.tokens().size() > 1 && m_reader.tokens()[1] == "BINARY")
                    return;
                k = 1;
            } else if (ends_with_off(first)) {
                return; // 4OFF, nOFF: other vertex layouts, left to assimp
            } else {
                std::int64_t value = 0;
                if (!text_io::parse_integer(first, value))
                    return; // not an OFF we know: left to assimp
            }
            read_counts(k);
            check_vertices();
            check_faces();
        }

    private:
        /// The three counts "vertices faces edges": the rest of the current line from token k
        /// on, or the next line if nothing follows the keyword.
        void read_counts(std::size_t k)
        {
            if (k >= m_reader.tokens().size()) {
                if (!m_reader.next())
                    fail("header: expected the 3 counts 'vertices faces edges', found none");
                k = 0;
            }
            const auto& tokens = m_reader.tokens();
            if (tokens.size() - k != 3)
                fail("header: expected the 3 counts 'vertices faces edges', found {} values",
                    tokens.size() - k);
            for (int c = 0; c < 3; ++c) {
                std::int64_t value = 0;
                if (!text_io::parse_integer(tokens[k + c], value) || value < 0)
                    fail("header: count {} is not a non-negative integer (expected the counts "
                         "'vertices faces edges')",
                        quote(tokens[k + c]));
                m_counts[c] = value;
            }
            m_header_line = m_reader.line_number();
            if (m_counts[0] == 0)
                fail("the header announces no vertices");
            if (m_counts[1] == 0)
                fail("the header announces no faces");
        }

        void check_vertices()
        {
            for (std::int64_t v = 0; v < m_counts[0]; ++v) {
                if (!m_reader.next())
                    throw_error("{}: line {}: the header announces {} vertices and {} faces, but "
                                "the file has only {} lines after it",
                        m_name, m_header_line, m_counts[0], m_counts[1], v);
                const auto& tokens = m_reader.tokens();
                if (tokens.size() < 3)
                    fail("vertex {} has {} coordinate(s), expected 3 (x y z)", v, tokens.size());
                for (std::size_t c = 0; c < 3; ++c) {
                    double value = 0.0;
                    if (!text_io::parse_real(tokens[c], value))
                        fail("vertex {}: coordinate {} is not a number", v, quote(tokens[c]));
                }
            }
        }

        void check_faces()
        {
            for (std::int64_t f = 0; f < m_counts[1]; ++f) {
                if (!m_reader.next())
                    throw_error("{}: line {}: the header announces {} vertices and {} faces, but "
                                "the file has only {} face lines after its {} vertex lines",
                        m_name, m_header_line, m_counts[0], m_counts[1], f, m_counts[0]);
                const auto& tokens = m_reader.tokens();
                std::int64_t size = 0;
                if (!text_io::parse_integer(tokens[0], size))
                    fail("face {}: vertex count {} is not an integer", f, quote(tokens[0]));
                if (size < 1)
                    fail("face {} has {} vertices", f, size);
                if (size > max_face_size)
                    fail("face {} has {} vertices, more than the {} the OFF reader takes", f, size,
                        max_face_size);
                if (static_cast<std::int64_t>(tokens.size()) - 1 < size)
                    fail("face {} announces {} vertices but lists {}", f, size, tokens.size() - 1);
                for (std::int64_t i = 1; i <= size; ++i) {
                    std::int64_t index = 0;
                    if (!text_io::parse_integer(tokens[i], index))
                        fail("face {}: vertex index {} is not an integer", f, quote(tokens[i]));
                    if (index < 0 || index >= m_counts[0])
                        fail("face {}: vertex index {} out of range: the file has {} vertices "
                             "(valid 0..{})",
                            f, index, m_counts[0], m_counts[0] - 1);
                }
            }
        }

        std::int64_t m_counts[3] = { 0, 0, 0 };
        int m_header_line = 0;
    };

    const char* obj_element_name(std::string_view letter)
    {
        return letter == "f" ? "face" : (letter == "l" ? "polyline" : "point");
    }

    class ObjChecker : public text_io::LineParser {
    public:
        using LineParser::LineParser;

        void check(std::string_view text)
        {
            std::int64_t total = 0;
            for (text_io::LineReader count(text); count.next();)
                total += count.tokens()[0] == "v";
            std::int64_t defined = 0;
            std::int64_t elements[3] = { 0, 0, 0 }; // f, l, p records so far
            while (m_reader.next()) {
                const std::string_view letter = m_reader.tokens()[0];
                if (letter == "v") {
                    ++defined;
                    continue;
                }
                const int kind = letter == "f" ? 0 : (letter == "l" ? 1 : (letter == "p" ? 2 : -1));
                if (kind < 0)
                    continue;
                const std::int64_t element = elements[kind]++;
                for (std::size_t k = 1; k < m_reader.tokens().size(); ++k)
                    check_index(
                        m_reader.tokens()[k], obj_element_name(letter), element, total, defined);
            }
        }

    private:
        /// One corner "v", "v/t", "v//n" or "v/t/n": its vertex index v.
        void check_index(std::string_view corner, const char* name, std::int64_t element,
            std::int64_t total, std::int64_t defined) const
        {
            const std::string_view token = corner.substr(0, corner.find('/'));
            std::int64_t index = 0;
            if (!text_io::parse_integer(token, index))
                fail("{} {}: vertex index {} is not an integer", name, element, quote(token));
            if (index == 0)
                fail("{} {}: vertex index 0: OBJ indices start at 1", name, element);
            if (index > total)
                fail("{} {}: vertex index {} out of range: the file has {} vertices (valid "
                     "1..{})",
                    name, element, index, total, total);
            if (index < 0 && -index > defined)
                fail("{} {}: vertex index {} out of range: it counts back from the {} vertices "
                     "before this line",
                    name, element, index, defined);
        }
    };

} // namespace

namespace {

    /// Walks an ASCII STL's records; fails at the first one out of place.
    class StlChecker : public text_io::LineParser {
    public:
        using LineParser::LineParser;

        void check()
        {
            // solid [name] { facet [normal x y z] / outer loop / 3 x vertex x y z / endloop /
            // endfacet } endsolid [name], possibly several solids.
            std::int64_t facet = 0;
            while (m_reader.next()) {
                const std::string_view word = m_reader.tokens()[0];
                if (word == "solid" || word == "endsolid")
                    continue;
                if (word != "facet")
                    fail("expected 'facet' or 'endsolid', found {}", quote(word));
                expect_word("outer", facet, "outer loop");
                int vertices = 0;
                while (next_in_facet(facet, vertices) && m_reader.tokens()[0] == "vertex") {
                    if (m_reader.tokens().size() < 4)
                        fail("facet {}: vertex {} has {} coordinates, expected 3", facet, vertices,
                            m_reader.tokens().size() - 1);
                    for (std::size_t k = 1; k < 4; ++k) {
                        double x = 0.0;
                        if (!text_io::parse_real(m_reader.tokens()[k], x))
                            fail("facet {}: vertex {}: coordinate {} is not a number", facet,
                                vertices, quote(m_reader.tokens()[k]));
                    }
                    ++vertices;
                }
                if (m_reader.tokens()[0] != "endloop")
                    fail("facet {}: expected 'vertex' or 'endloop', found {}", facet,
                        quote(m_reader.tokens()[0]));
                if (vertices != 3)
                    fail("facet {}: {} vertices, an STL facet has 3", facet, vertices);
                expect_word("endfacet", facet, "endfacet");
                ++facet;
            }
        }

    private:
        bool next_in_facet(std::int64_t facet, int vertices)
        {
            if (!m_reader.next())
                fail_at_end(facet, vertices);
            return true;
        }
        void expect_word(std::string_view word, std::int64_t facet, const char* record)
        {
            if (!m_reader.next())
                fail_at_end(facet, -1);
            if (m_reader.tokens()[0] != word)
                fail("facet {}: expected '{}', found {}", facet, record,
                    quote(m_reader.tokens()[0]));
        }
        [[noreturn]] void fail_at_end(std::int64_t facet, int vertices) const
        {
            // At the end, line_number() is one past the last line.
            const int last = m_reader.line_number() - 1;
            if (vertices >= 0)
                throw_error("{}: the file ends after line {}, inside facet {} after {} of its 3 "
                            "vertices: it is truncated",
                    m_name, last, facet, vertices);
            throw_error("{}: the file ends after line {}, inside facet {}: it is truncated", m_name,
                last, facet);
        }
    };

    /// Whether `path` holds an ASCII STL: "solid" first, and not the size of a binary one (an
    /// 80-byte header, a 4-byte count, 50 bytes per triangle).
    bool is_ascii_stl(const std::string& path, const std::string& text)
    {
        if (lower_extension(path) != ".stl" || text.compare(0, 5, "solid") != 0)
            return false;
        if (text.size() >= 84) {
            std::uint32_t count = 0;
            std::memcpy(&count, text.data() + 80, sizeof(count));
            if (84 + 50 * static_cast<std::uint64_t>(count) == text.size())
                return false;
        }
        return true;
    }

} // namespace

std::string explain_import_failure(const std::string& path)
{
    std::string text;
    try {
        text = text_io::read_file(path);
    } catch (const Error&) {
        return "";
    }
    try {
        if (is_ascii_stl(path, text))
            StlChecker(text, path).check();
        if (lower_extension(path) == ".gltf") {
            try {
                const nlohmann::json parsed = nlohmann::json::parse(text);
                static_cast<void>(parsed);
            } catch (const nlohmann::json::parse_error& e) {
                // e.what(): "[json.exception.parse_error.101] parse error at line 1, column 5:
                // syntax error while parsing ...": keep what follows "parse error ".
                const std::string what = e.what();
                const std::size_t at = what.find("parse error ");
                return fmt::format("{}: the glTF is not valid JSON: {}", path,
                    at == std::string::npos ? what : what.substr(at + 12));
            }
        }
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

void check_obj_text(const std::string& path)
{
    const std::string text = text_io::read_file(path);
    ObjChecker(text, path).check(text);
}

void check_off_text(const std::string& path)
{
    if (lower_extension(path) != ".off") {
        // assimp also takes a file whose first word ends in OFF, whatever its extension.
        std::ifstream in(path, std::ios::binary);
        std::string head(4096, '\0');
        in.read(head.data(), static_cast<std::streamsize>(head.size()));
        head.resize(static_cast<std::size_t>(in.gcount()));
        text_io::LineReader reader(head);
        if (!reader.next() || !ends_with_off(reader.tokens()[0]))
            return;
    }
    const std::string text = text_io::read_file(path);
    OffChecker(text, path).check();
}

} // namespace mat::detail
