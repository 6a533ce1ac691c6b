#pragma once
// `mat-bake sample NAME|all -o DIR [--facet-size F] [--detail D]`: regenerate the bundled
// samples (a surface and its exact medial mesh each) into DIR/NAME/NAME.{obj,ma}.

#include <string>

#include <CLI/CLI.hpp>

namespace mat {

struct SampleCommandOptions {
    std::string name;
    std::string output;
    double facet_size = 0.0;
    int detail = 2;
};

CLI::App* add_sample_command(CLI::App& app, SampleCommandOptions& options);

void run_sample_command(const SampleCommandOptions& options);

} // namespace mat
