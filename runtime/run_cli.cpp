#include "runtime/run_cli.hpp"

#include <cstdio>
#include <string>

#include "common/cli.hpp"
#include "runtime/run_command.hpp"
#include "runtime/scene/scene.hpp"

namespace mat {

namespace {

    /// "WIDTHxHEIGHT" -> width, height; false unless both are positive integers.
    bool parse_image_size(const std::string& text, int& width, int& height)
    {
        int w = 0, h = 0;
        char x = 0, extra = 0;
        if (std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || x != 'x' || w <= 0
            || h <= 0)
            return false;
        width = w;
        height = h;
        return true;
    }

} // namespace

int run_main(int argc, char** argv)
{
    CLI::App app { "mat-run: simulate baked medial-elastic bodies from a scene file and write "
                   "frames",
        "mat-run" };
    CommonOptions common;
    add_common_options(app, common);
    RunOptions options;
    bool reference = false;
    std::string preview_size = "640x480";
    app.add_option("scene", options.scene, "Scene file (JSON; see --scene-reference)")
        ->check(CLI::ExistingFile);
    app.add_option("-o,--output", options.output, "Output directory (created if missing)");
    app.add_option("--frames", options.frames, "Output frames to run (overrides the scene)")
        ->check(whole_number_at_least(1));
    app.add_option("--solver", options.solver,
           "semi: semi-reduced PD (reduced global step); full: full-space PD (reference); hyper: "
           "hyper-reduced PD (local step on sampled tets, solver.hyper_samples)")
        ->check(CLI::IsMember({ "semi", "full", "hyper" }))
        ->capture_default_str();
    app.add_option("--device", options.device,
           "cpu, or cuda: the semi-reduced step on the GPU (overrides solver.device; needs a "
           "build with -DMAT_CUDA=ON and a CUDA device)")
        ->check(CLI::IsMember({ "cpu", "cuda" }));
    app.add_option("--stats", options.stats,
        "Write per-frame timings, iterations, energies, strain and contacts as JSON");
    app.add_flag("--check-collisions", options.check_collisions,
        "After each step, compare the collision world's triangle pairs with an exhaustive check "
        "and measure the penetration (slow: for testing; results in the summary and --stats)");
    app.add_flag("--preview", options.preview,
        "Render each output frame to OUTDIR/preview/frame_NNNNN.png (fixed camera, flat shading, "
        "a color per object) and, where ffmpeg is on PATH, assemble OUTDIR/preview.mp4");
    app.add_option("--preview-size", preview_size, "Preview image size WIDTHxHEIGHT in pixels")
        ->capture_default_str();
    app.add_option("--reference", options.reference,
           "Trajectory cache (trajectory.h5 of an earlier run of this scene, e.g. full-space PD at "
           "many iterations): write this run's trajectory.h5 too and report the RMS and max "
           "surface distance to it (% of its bounding-box diagonal, max over frames)")
        ->check(CLI::ExistingFile);
    app.add_flag("--resume", options.resume,
        "Continue the run in -o DIR from its last checkpoint (a killed run, or a finished one for "
        "more --frames); without a checkpoint, start at frame 0");
    app.add_option("--checkpoint-every", options.checkpoint_every,
           "Frames between checkpoints for --resume (OUTDIR/checkpoint.h5; 0: the last frame "
           "only)")
        ->capture_default_str();
    app.add_option("--progress-every", options.progress_every,
           "Seconds between progress lines (frame, time simulated, ms/step) when stderr is not a "
           "terminal (0: none)")
        ->capture_default_str();
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
        if (!parse_image_size(preview_size, options.preview_width, options.preview_height))
            throw CLI::ValidationError(
                "--preview-size", "'" + preview_size + "' is not WIDTHxHEIGHT (e.g. 480x360)");
        run_simulation(options);
    });
}

} // namespace mat
