#include "runtime/run_cli.hpp"

#include <cstdio>

#include "common/cli.hpp"
#include "runtime/run_command.hpp"
#include "runtime/scene/scene.hpp"

namespace mat {

int run_main(int argc, char** argv)
{
    CLI::App app { "mat-run: simulate baked medial-elastic bodies from a scene file and write "
                   "frames",
        "mat-run" };
    CommonOptions common;
    add_common_options(app, common);
    RunOptions options;
    bool reference = false;
    app.add_option("scene", options.scene, "Scene file (JSON; see --scene-reference)")
        ->check(CLI::ExistingFile);
    app.add_option("-o,--output", options.output, "Output directory (created if missing)");
    app.add_option("--frames", options.frames, "Output frames to run (overrides the scene)")
        ->check(CLI::PositiveNumber);
    app.add_option("--solver", options.solver,
           "semi: semi-reduced PD (reduced global step); full: full-space PD (reference)")
        ->check(CLI::IsMember({ "semi", "full" }))
        ->capture_default_str();
    app.add_option("--stats", options.stats,
        "Write per-frame timings, iterations, energies, strain and contacts as JSON");
    app.add_flag("--check-collisions", options.check_collisions,
        "After each step, compare the collision world's triangle pairs with an exhaustive check "
        "and measure the penetration (slow: for testing; results in the summary and --stats)");
    app.add_flag("--scene-reference", reference,
        "Print every scene key with its type, default and doc (Markdown), then exit");
    return run_cli(app, argc, argv, [&] {
        apply_common_options(common);
        if (reference) {
            std::fputs(scene_reference_markdown().c_str(), stdout);
            return;
        }
        if (options.scene.empty() || options.output.empty())
            throw CLI::RequiredError("mat-run needs SCENE and -o DIR");
        run_simulation(options);
    });
}

} // namespace mat
