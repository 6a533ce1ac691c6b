#pragma once
// What every command-line tool shares: --version, --log-level, --threads, and a main() wrapper
// that turns errors into one line on stderr and the exit codes 0 ok, 1 failure, 2 usage.

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace mat {

struct CommonOptions {
    std::string log_level = "info";
    int threads = 0; ///< 0: all cores
};

/// A check for a whole-number option in [min, max], whose failure reads in plain words:
/// "--spheres: must be at least 1, got 0" (CLI11's own Range and PositiveNumber print the
/// limits of double in full). docs/mat-bake.md and docs/mat-run.md list the ranges.
CLI::Validator whole_number_in(long long min, long long max);

/// A check for a whole-number option of at least min ("must be at least 1, got 0").
CLI::Validator whole_number_at_least(long long min);

/// Adds --version, --log-level and --threads to app, bound to options.
void add_common_options(CLI::App& app, CommonOptions& options);

/// Applies the common options (logger level, thread count). Throws mat::Error if invalid.
void apply_common_options(const CommonOptions& options);

/// Parses argv into app, then runs body. Returns the process exit code:
/// 0 on success, 2 on a usage error (unknown option, missing argument; a body may throw a
/// CLI::ParseError for arguments it finds incomplete), 1 on any other error.
/// Errors print as one line "TOOL: error: MESSAGE" on stderr.
int run_cli(CLI::App& app, int argc, char** argv, const std::function<void()>& body);

} // namespace mat
