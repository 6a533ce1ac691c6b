#pragma once
// `mat-bake medial SURFACE -o OUT.ma --spheres N`: generate a medial mesh for a bare closed
// surface (preprocess/medial/medial_generator.hpp) and write it as a Q-MAT .ma file.

#include <string>

#include <CLI/CLI.hpp>

#include "preprocess/bake/bake_inputs.hpp"
#include "preprocess/medial/medial_generator.hpp"

namespace mat {

struct MedialCommandOptions {
    std::string surface;
    std::string output;
    MedialGeneratorOptions generator;
    InputChecks checks; ///< --allow-self-intersections
};

/// Adds the `medial` subcommand to app; its options land in options.
CLI::App* add_medial_command(CLI::App& app, MedialCommandOptions& options);

/// Adds the generator's tuning options (--samples) to a command; shared by `medial` and the
/// bake's --spheres.
void add_medial_generator_options(CLI::App& command, MedialGeneratorOptions& options);

/// Reads the surface, generates, writes the .ma atomically, prints the quality line.
void run_medial_command(const MedialCommandOptions& options);

} // namespace mat
