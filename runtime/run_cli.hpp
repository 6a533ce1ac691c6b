#pragma once

namespace mat {

/// The whole mat-run command line: parses argv, runs, returns the exit code.
int run_main(int argc, char** argv);

} // namespace mat
