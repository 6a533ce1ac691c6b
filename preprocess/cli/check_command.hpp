#pragma once
// `mat-bake check SURFACE [--medial FILE.ma]`: read and validate the inputs of a bake and print
// what was read. Exits 1 (via mat::Error) if the surface cannot bound a solid or the medial mesh
// is invalid.

#include <string>

#include <CLI/CLI.hpp>

namespace mat {

struct CheckOptions {
    std::string surface;
    std::string medial;
};

/// Adds the `check` subcommand to app; its options land in options.
CLI::App* add_check_command(CLI::App& app, CheckOptions& options);

/// Runs the check; prints the summary on stdout.
void run_check(const CheckOptions& options);

} // namespace mat
