#pragma once
// One error type for every user-facing failure: bad input, I/O, solver breakdown. Its message is
// one line a user can act on: the file, the element (line, index) and what was expected.
// main() catches it, prints the line and exits 1.

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace mat {

class Error : public std::runtime_error {
public:
    explicit Error(const std::string& message);
};

/// Throws mat::Error with a fmt-formatted message.
template <typename... Args>
[[noreturn]] void throw_error(fmt::format_string<Args...> format, Args&&... args)
{
    throw Error(fmt::format(format, std::forward<Args>(args)...));
}

namespace detail {
    [[noreturn]] void check_failed(
        const char* condition, const char* file, int line, const std::string& message);
}

} // namespace mat

/// A checked assertion that stays on in Release builds, for API boundaries and solver results.
/// On failure it throws mat::Error naming the condition, the source location and the message.
#define MAT_CHECK(condition, ...)                                                                  \
    do {                                                                                           \
        if (!(condition))                                                                          \
            ::mat::detail::check_failed(                                                           \
                #condition, __FILE__, __LINE__, ::fmt::format(__VA_ARGS__));                       \
    } while (false)
