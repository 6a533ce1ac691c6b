#include "preprocess/cli/medial_command.hpp"

#include <cstdio>

#include "common/cli.hpp"
#include "common/progress.hpp"
#include "formats/medial_io.hpp"
#include "preprocess/cli/check_command.hpp"

namespace mat {

void add_medial_generator_options(CLI::App& command, MedialGeneratorOptions& options)
{
    command
        .add_option("--samples", options.samples,
            "Surface samples for the Voronoi diagram (more: finer detail, slower)")
        ->capture_default_str();
    command
        .add_option("--medial-query-bound", options.query_bound,
            "Bound on the medial simplification's surface queries per initial sphere; past it the "
            "generator stops with an error")
        ->capture_default_str();
}

CLI::App* add_medial_command(CLI::App& app, MedialCommandOptions& options)
{
    CLI::App* medial = app.add_subcommand(
        "medial", "Generate a medial mesh (.ma, Q-MAT dialect) for a closed surface");
    medial->add_option("surface", options.surface, "Closed surface (OBJ, PLY, STL, OFF, glTF, ...)")
        ->required()
        ->check(CLI::ExistingFile);
    medial->add_option("-o,--output", options.output, "The .ma file to write")->required();
    medial->add_option("--spheres", options.generator.spheres, "Number of spheres")
        ->capture_default_str()
        ->check(whole_number_at_least(1));
    add_medial_generator_options(*medial, options.generator);
    add_input_check_options(*medial, options.checks);
    return medial;
}

void run_medial_command(const MedialCommandOptions& options)
{
    const CheckedSurface checked = inspect_surface(options.surface);
    require_bake_surface(checked, options.surface, options.checks);
    const SurfaceMesh& surface = checked.surface;
    MedialGeneratorOptions generator = options.generator;
    generator.surface_name = options.surface;
    MedialQuality quality;
    MedialMesh medial;
    {
        const ProgressHeartbeat heartbeat("medial generator");
        medial = generate_medial_mesh(surface, generator, &quality);
    }
    write_medial(options.output, medial, MedialDialect::qmat);
    // The quality line is logged by the generator.
    std::printf("wrote %s: %lld spheres, %lld cones, %lld slabs, Hausdorff %.3f%% of the "
                "diagonal\n",
        options.output.c_str(), static_cast<long long>(medial.num_spheres()),
        static_cast<long long>(medial.num_cones()), static_cast<long long>(medial.num_slabs()),
        quality.hausdorff_percent());
}

} // namespace mat
