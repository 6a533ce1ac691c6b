#pragma once
// The main job of mat-bake: `mat-bake SURFACE --medial FILE.ma -o OUT.h5 [options]`, and
// `mat-bake inspect OUT.h5`, which prints a readable summary of a bake.

#include <CLI/CLI.hpp>

#include "preprocess/bake/bake_pipeline.hpp"

namespace mat {

/// Adds the bake's positional surface and its options to the top-level app.
void add_bake_options(CLI::App& app, BakeOptions& options);

/// mat-bake --error E: chooses the model's size (model_size_search.hpp), writes the chosen bake
/// atomically, prints every candidate tried and the chosen one.
void run_model_size_command(const BakeOptions& options);

/// Runs the bake, writes the file atomically, prints the summary and the stage table.
void run_bake_command(const BakeOptions& options);

/// Adds the `inspect` subcommand; its file lands in path.
CLI::App* add_inspect_command(CLI::App& app, std::string& path);

/// Prints a readable summary of a bake file on stdout.
void run_inspect(const std::string& path);

} // namespace mat
