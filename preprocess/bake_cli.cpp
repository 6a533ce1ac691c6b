#include "preprocess/bake_cli.hpp"

#include "common/cli.hpp"
#include "common/log.hpp"
#include "preprocess/cli/bake_command.hpp"
#include "preprocess/cli/check_command.hpp"
#include "preprocess/cli/medial_command.hpp"
#include "preprocess/cli/sample_command.hpp"

namespace mat {

int bake_main(int argc, char** argv)
{
    CLI::App app {
        "mat-bake: turn a closed surface and its medial mesh into one HDF5 bake.\n"
        "  mat-bake SURFACE --medial FILE.ma -o OUT.h5 [options]\n"
        "  mat-bake SURFACE --spheres N -o OUT.h5 [options]   (generates the medial mesh)\n"
        "  mat-bake medial SURFACE -o OUT.ma --spheres N\n"
        "  mat-bake inspect OUT.h5 | check SURFACE [--medial FILE.ma] | sample NAME -o DIR",
        "mat-bake"
    };
    CommonOptions common;
    add_common_options(app, common);
    app.require_subcommand(0, 1);

    BakeOptions bake_options;
    add_bake_options(app, bake_options);
    CheckOptions check_options;
    CLI::App* check = add_check_command(app, check_options);
    std::string inspect_path;
    CLI::App* inspect = add_inspect_command(app, inspect_path);
    SampleCommandOptions sample_options;
    CLI::App* sample = add_sample_command(app, sample_options);
    MedialCommandOptions medial_options;
    CLI::App* medial = add_medial_command(app, medial_options);

    return run_cli(app, argc, argv, [&] {
        apply_common_options(common);
        if (check->parsed())
            run_check(check_options);
        else if (inspect->parsed())
            run_inspect(inspect_path);
        else if (sample->parsed())
            run_sample_command(sample_options);
        else if (medial->parsed())
            run_medial_command(medial_options);
        else
            run_bake_command(bake_options);
    });
}

} // namespace mat
