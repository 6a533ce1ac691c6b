#include "formats/text_io.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "common/error.hpp"
#include "formats/atomic_file.hpp"

namespace mat::text_io {

namespace {
    bool is_space(char c)
    {
        return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
    }

    // from_chars accepts no leading '+': drop one if a digit or '.' follows.
    std::string_view strip_plus(std::string_view token)
    {
        if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+')
            return token.substr(1);
        return token;
    }
} // namespace

LineReader::LineReader(std::string_view text)
    : m_text(text)
{
}

bool LineReader::next()
{
    while (m_pos < m_text.size()) {
        std::size_t end = m_text.find('\n', m_pos);
        if (end == std::string_view::npos)
            end = m_text.size();
        std::string_view line = m_text.substr(m_pos, end - m_pos);
        m_pos = end + 1;
        m_line_number = m_next_line_number++;
        const std::size_t hash = line.find('#');
        if (hash != std::string_view::npos)
            line = line.substr(0, hash);
        m_tokens.clear();
        std::size_t i = 0;
        while (i < line.size()) {
            while (i < line.size() && is_space(line[i]))
                ++i;
            const std::size_t start = i;
            while (i < line.size() && !is_space(line[i]))
                ++i;
            if (i > start)
                m_tokens.push_back(line.substr(start, i - start));
        }
        if (!m_tokens.empty())
            return true;
    }
    m_tokens.clear();
    m_line_number = m_next_line_number;
    return false;
}

double LineParser::real_field(std::size_t k, const char* field) const
{
    const std::string_view token = m_reader.tokens()[k];
    double value = 0.0;
    if (!parse_real(token, value))
        fail("value {} of field '{}' is not a number", quote(token), field);
    if (!std::isfinite(value))
        fail("value {} of field '{}' is not finite", quote(token), field);
    return value;
}

bool parse_integer(std::string_view token, std::int64_t& value)
{
    token = strip_plus(token);
    if (token.empty())
        return false;
    const char* first = token.data();
    const char* last = first + token.size();
    const auto result = std::from_chars(first, last, value);
    return result.ec == std::errc() && result.ptr == last;
}

bool parse_real(std::string_view token, double& value)
{
    token = strip_plus(token);
    if (token.empty())
        return false;
    const char* first = token.data();
    const char* last = first + token.size();
    const auto result = std::from_chars(first, last, value, std::chars_format::general);
    if (result.ptr != last)
        return false;
    if (result.ec == std::errc::result_out_of_range) {
        // Valid syntax, beyond the double range: strtod gives +-HUGE_VAL on overflow (left for
        // the caller's finiteness check) and 0 or a subnormal on underflow (a usable value).
        const std::string copy(token);
        value = std::strtod(copy.c_str(), nullptr);
        return true;
    }
    return result.ec == std::errc();
}

std::string quote(std::string_view token)
{
    constexpr std::size_t max_shown = 40;
    std::string out = "'";
    for (std::size_t i = 0; i < token.size() && i < max_shown; ++i) {
        const auto c = static_cast<unsigned char>(token[i]);
        if (c < 0x20 || c >= 0x7f || c == '\'')
            out += fmt::format("\\x{:02x}", c);
        else
            out += static_cast<char>(c);
    }
    if (token.size() > max_shown)
        out += "...";
    out += "'";
    return out;
}

std::string read_file(const std::string& path)
{
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
        throw_error("{}: cannot open for reading: it is a directory", path);
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw_error("{}: cannot open for reading: {}", path, std::strerror(errno));
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad())
        throw_error("{}: read error", path);
    return std::move(buffer).str();
}

void write_file(const std::string& path, std::string_view text, const std::string& target)
{
    std::FILE* file = std::fopen(path.c_str(), "wb");
    if (!file)
        throw_error("{}: cannot write: {}", target, std::strerror(errno));
    const bool complete = std::fwrite(text.data(), 1, text.size(), file) == text.size();
    const int write_errno = errno;
    if (!complete) {
        std::fclose(file);
        throw_error("{}: cannot write: {}", target, std::strerror(write_errno));
    }
    if (std::fclose(file) != 0)
        throw_error("{}: cannot write: {}", target, std::strerror(errno));
}

void write_file_atomically(const std::string& path, std::string_view text)
{
    AtomicFile file(path);
    write_file(file.temp_path(), text, path);
    file.commit();
}

} // namespace mat::text_io
