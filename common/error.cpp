#include "common/error.hpp"

namespace mat {

namespace {
    // An error message is one line: fold any newline so that the CLI prints exactly one line.
    std::string one_line(std::string text)
    {
        for (char& c : text)
            if (c == '\n' || c == '\r')
                c = ' ';
        return text;
    }
} // namespace

Error::Error(const std::string& message)
    : std::runtime_error(one_line(message))
{
}

namespace detail {
    void check_failed(const char* condition, const char* file, int line, const std::string& message)
    {
        throw Error(
            fmt::format("internal check failed: {} ({} at {}:{})", message, condition, file, line));
    }
} // namespace detail

} // namespace mat
