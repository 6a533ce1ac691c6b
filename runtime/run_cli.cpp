#include "runtime/run_cli.hpp"

#include "common/cli.hpp"

namespace mat {

int run_main(int argc, char** argv)
{
    CLI::App app { "mat-run: simulate baked medial-elastic bodies from a scene file", "mat-run" };
    CommonOptions common;
    add_common_options(app, common);
    return run_cli(app, argc, argv, [&] { apply_common_options(common); });
}

} // namespace mat
