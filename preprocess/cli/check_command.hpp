#pragma once
// `mat-bake check SURFACE [--medial FILE.ma]`: read and validate the inputs of a bake and print
// what was read. Exits 1 (via mat::Error) with the bake's own line where the bake would refuse
// them (preprocess/bake/bake_inputs.hpp).

#include <string>

#include <CLI/CLI.hpp>

#include "preprocess/bake/bake_inputs.hpp"

namespace mat {

struct CheckOptions {
    std::string surface;
    std::string medial;
    InputChecks checks;
};

/// Adds the `check` subcommand to app; its options land in options.
CLI::App* add_check_command(CLI::App& app, CheckOptions& options);

/// Adds --allow-self-intersections (shared by check, medial and the bake).
void add_input_check_options(CLI::App& command, InputChecks& checks);

/// Runs the check; prints the summary on stdout.
void run_check(const CheckOptions& options);

} // namespace mat
