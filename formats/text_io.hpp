#pragma once
// Text-reading helpers shared by the medial (.ma) and tet mesh (.mesh, .node/.ele) readers and
// writers: a line cursor that strips '#' comments, a parser base that reports errors by line,
// strict number parsing, and whole-file I/O. Internal to formats/: nothing outside the readers
// should need it.

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/error.hpp"

namespace mat::text_io {

/// Walks the lines of a text, skipping blank and comment-only lines. A '#' starts a comment
/// that runs to the end of its line; '\r' counts as whitespace, so CRLF files read the same.
class LineReader {
public:
    /// `text` must outlive the reader: tokens are views into it.
    explicit LineReader(std::string_view text);

    /// Moves to the next line that has at least one token. Returns false at the end of the text,
    /// after which line_number() is one past the last line.
    bool next();

    /// The 1-based number of the current line.
    int line_number() const { return m_line_number; }
    /// Whitespace-separated tokens of the current line (comments removed).
    const std::vector<std::string_view>& tokens() const { return m_tokens; }

private:
    std::string_view m_text;
    std::size_t m_pos = 0;
    int m_line_number = 0;
    int m_next_line_number = 1;
    std::vector<std::string_view> m_tokens;
};

/// Base of the line-oriented parsers: a LineReader over the text and the name errors cite.
class LineParser {
public:
    /// `text` and `name` must outlive the parser.
    LineParser(std::string_view text, const std::string& name)
        : m_reader(text)
        , m_name(name)
    {
    }

    /// Throws mat::Error "<name>: line <current line>: <message>".
    template <typename... Args>
    [[noreturn]] void fail(fmt::format_string<Args...> format, Args&&... args) const
    {
        throw_error("{}: line {}: {}", m_name, m_reader.line_number(),
            fmt::format(format, std::forward<Args>(args)...));
    }

protected:
    /// Token `k` of the current line as a finite number; fails with "value 'x' of field
    /// '<field>' is not a number" (or "is not finite").
    double real_field(std::size_t k, const char* field) const;

    LineReader m_reader;
    const std::string& m_name;
};

/// Parses a whole token as a decimal integer (optional sign). False if anything is left over,
/// the token is empty or the value overflows.
bool parse_integer(std::string_view token, std::int64_t& value);

/// Parses a whole token as a floating-point number (optional sign, decimal or exponent form;
/// "inf"/"nan" parse and are left for the caller to reject as non-finite). False if anything
/// is left over or the token is empty. A value beyond the double range gives +-inf (overflow)
/// or 0 / a subnormal (underflow).
bool parse_real(std::string_view token, double& value);

/// A token quoted for an error message: 'token', cut to a readable length, control characters
/// and non-ASCII bytes escaped as \xNN so that the message stays one printable line.
std::string quote(std::string_view token);

/// The whole content of a file. Throws mat::Error naming the path if it cannot be read.
std::string read_file(const std::string& path);

/// Writes `text` to `path` (a temporary path of an AtomicFile). Throws mat::Error naming
/// `target` on any I/O failure.
void write_file(const std::string& path, std::string_view text, const std::string& target);

/// Writes `text` to `path` atomically (an AtomicFile: a temporary beside it, renamed at the end;
/// nothing is left at `path` on failure). Throws mat::Error naming `path` on any I/O failure.
void write_file_atomically(const std::string& path, std::string_view text);

} // namespace mat::text_io
