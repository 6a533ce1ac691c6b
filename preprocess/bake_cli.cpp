#include "preprocess/bake_cli.hpp"

#include "common/cli.hpp"
#include "common/log.hpp"

namespace mat {

int bake_main(int argc, char** argv)
{
    CLI::App app { "mat-bake: turn a closed surface and its medial mesh into one HDF5 bake",
        "mat-bake" };
    CommonOptions common;
    add_common_options(app, common);
    app.require_subcommand(0, 1);
    return run_cli(app, argc, argv, [&] { apply_common_options(common); });
}

} // namespace mat
