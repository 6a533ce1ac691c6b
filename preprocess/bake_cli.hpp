#pragma once

namespace mat {

/// The whole mat-bake command line: parses argv, runs the subcommand, returns the exit code.
int bake_main(int argc, char** argv);

} // namespace mat
