#pragma once
// Checks on the one-line mat::Error messages thrown for bad input.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/error.hpp"

namespace mat::test {

/// Runs `read` and expects a mat::Error whose message starts "<file>: line <line>: " and
/// contains `what`.
template <typename Read>
void expect_line_error(Read&& read, const std::string& file, int line, const std::string& what)
{
    try {
        read();
        ADD_FAILURE() << "no error, expected " << what;
    } catch (const Error& e) {
        const std::string message = e.what();
        const std::string prefix = fmt::format("{}: line {}: ", file, line);
        EXPECT_EQ(message.rfind(prefix, 0), 0u) << message << "\nexpected " << prefix;
        EXPECT_NE(message.find(what), std::string::npos) << message << "\nexpected " << what;
    }
}

/// Runs `run` and expects a mat::Error whose message contains every one of `parts`.
template <typename Run>
void expect_error_containing(Run&& run, const std::vector<std::string>& parts)
{
    try {
        run();
        ADD_FAILURE() << "no mat::Error thrown";
    } catch (const Error& e) {
        const std::string message = e.what();
        for (const std::string& part : parts)
            EXPECT_NE(message.find(part), std::string::npos)
                << "'" << part << "' not in: " << message;
    }
}

} // namespace mat::test
