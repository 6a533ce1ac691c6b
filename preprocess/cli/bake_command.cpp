#include "preprocess/cli/bake_command.hpp"

#include <cstdio>
#include <map>
#include <string>

#include "common/cli.hpp"
#include "common/log.hpp"
#include "common/timer.hpp"
#include "formats/bake_io.hpp"
#include "preprocess/cli/check_command.hpp"
#include "preprocess/cli/medial_command.hpp"
#include "preprocess/model_size/model_size_search.hpp"

namespace mat {

void add_bake_options(CLI::App& app, BakeOptions& options)
{
    app.add_option(
           "surface", options.surface, "Closed surface to bake (OBJ, PLY, STL, OFF, glTF, ...)")
        ->check(CLI::ExistingFile);
    CLI::Option* medial = app.add_option("--medial", options.medial,
                                 "Its medial mesh (.ma, Q-MAT or the paper's; Medial IPC's .mat)")
                              ->check(CLI::ExistingFile);
    app.add_option("--spheres", options.spheres,
           "Generate the medial mesh with this many spheres instead of reading --medial")
        ->check(whole_number_at_least(1))
        ->excludes(medial);
    add_medial_generator_options(app, options.generator);
    add_input_check_options(app, options.checks);
    app.add_option("-o,--output", options.output, "The bake file to write (.h5)");
    app.add_option("--unit", options.unit,
           "Length unit of SURFACE and --medial (centers and radii): mm, cm, m or in; the bake "
           "is in metres")
        ->check(CLI::IsMember({ "mm", "cm", "m", "in" }))
        ->capture_default_str();
    app.add_option(
           "--tet-size", options.tet_size, "Tet size as a fraction of the bounding-box diagonal")
        ->capture_default_str();
    app.add_option("--max-tet-vertices", options.max_tet_vertices,
           "Bound on the tet mesher's vertices; past it the bake stops with an error")
        ->check(whole_number_at_least(1))
        ->capture_default_str();
    app.add_option("--sliver-perturbation", options.perturb_slivers,
           "Perturb the tet mesh's slivers (on: rounder tets near the surface, for several "
           "times the meshing time; docs/method.md, section 2)")
        ->transform(
            CLI::Transformer(std::map<std::string, bool> { { "on", true }, { "off", false } }))
        ->default_str("on");
    app.add_option("--quadratic", options.quadratic,
           "Quadratic (30 DOF) handles: all, none, or a list of sphere indices 0,4,7")
        ->capture_default_str();
    app.add_option("--weights-per-node", options.weights_per_node,
           "Largest handle weights kept per node (sparsity)")
        ->capture_default_str();
    app.add_option("--error", options.error,
        "Choose the smallest model (spheres, quadratic handles, tet size) whose error against the "
        "full-space model on standard load cases stays within this % of the bbox diagonal; "
        "--spheres is then the most spheres tried, --tet-size the finest");
}

void run_model_size_command(const BakeOptions& options)
{
    if (options.surface.empty() || options.output.empty())
        throw CLI::RequiredError("mat-bake --error E needs SURFACE and -o");
    ModelSizeOptions search;
    search.error_percent = parse_error_percent(options.error);
    search.bake = options;
    if (options.quadratic != "none")
        logger().warn(
            "--quadratic {} is ignored: --error chooses the quadratic handles", options.quadratic);
    Timer total;
    const ModelSizeResult result = choose_model_size(search);
    write_bake(options.output, result.bake);
    std::fputs(result.table().c_str(), stdout);
    std::fputs(result.report.summary().c_str(), stdout);
    std::printf("chose %lld spheres, quadratic handles %s, tet size %.4g: error rms %.3f%%, max "
                "%.3f%% of the diagonal (within %g%%), %lld reduced DOF; searched in %.1f s\nwrote "
                "%s\n",
        static_cast<long long>(result.chosen.spheres), result.quadratic.c_str(),
        result.chosen.tet_size, result.chosen.error.rms_percent, result.chosen.error.max_percent,
        search.error_percent, static_cast<long long>(result.chosen.dof), total.seconds(),
        options.output.c_str());
}

void run_bake_command(const BakeOptions& options)
{
    if (!options.error.empty()) {
        run_model_size_command(options);
        return;
    }
    if (options.surface.empty() || (options.medial.empty() && options.spheres <= 0)
        || options.output.empty())
        throw CLI::RequiredError(
            "a bake needs SURFACE, --medial and -o (or --spheres N instead of --medial, or a "
            "subcommand)");
    Timer total;
    BakeReport report;
    const BakeData bake = run_bake(options, report);
    Timer write_timer;
    write_bake(options.output, bake);
    report.stages.add("write", write_timer.seconds());
    std::fputs(report.summary().c_str(), stdout);
    std::printf("wrote %s\n%s", options.output.c_str(), report.stages.table().c_str());
    logger().debug("bake done in {:.3f} s", total.seconds());
}

CLI::App* add_inspect_command(CLI::App& app, std::string& path)
{
    CLI::App* inspect = app.add_subcommand("inspect", "Print a readable summary of a bake file");
    inspect->add_option("bake", path, "Bake file (.h5)")->required()->check(CLI::ExistingFile);
    return inspect;
}

void run_inspect(const std::string& path)
{
    const BakeData b = read_bake(path);
    const MedialCollisionData& c = b.collision;
    const Index quadratic = b.handle_quadratic.sum();
    std::printf("%s: medial-elastics bake, format version %d, lengths in %s\n", path.c_str(),
        bake_format_version, b.length_unit.c_str());
    std::printf("  inputs: %s (%s)\n          %s (%s)\n", b.surface_file.c_str(),
        b.surface_hash.c_str(), b.medial_file.c_str(), b.medial_hash.c_str());
    std::printf("  options: %s\n", b.options_json.c_str());
    // The diagonal of the nodes' box: the body's size as mat-run measures margins and
    // penetrations against it (runtime/body_model.hpp).
    const MatX3& nodes = b.tet_mesh.positions;
    const double diagonal
        = nodes.rows() > 0 ? (nodes.colwise().maxCoeff() - nodes.colwise().minCoeff()).norm() : 0.0;
    std::printf("  tet mesh: %lld nodes, %lld tets, volume %.6g, bounding-box diagonal %.6g\n",
        static_cast<long long>(b.tet_mesh.num_vertices()),
        static_cast<long long>(b.tet_mesh.num_tets()), b.rest_volumes.sum(), diagonal);
    std::printf("  surface: %lld vertices, %lld faces (%lld outside the tet mesh, extrapolated)\n",
        static_cast<long long>(b.surface.num_vertices()),
        static_cast<long long>(b.surface.num_faces()),
        static_cast<long long>(b.surface_outside_count));
    std::printf("  medial mesh: %lld spheres, %lld cones, %lld slabs, radii inflated by %.4g\n",
        static_cast<long long>(b.medial.num_spheres()),
        static_cast<long long>(b.medial.num_cones()), static_cast<long long>(b.medial.num_slabs()),
        b.medial_inflation);
    std::printf("  handles: %lld (%lld quadratic), %lld basis columns, %lld reduced DOF\n",
        static_cast<long long>(b.num_handles()), static_cast<long long>(quadratic),
        static_cast<long long>(b.num_columns()), static_cast<long long>(3 * b.num_columns()));
    std::printf("  weights: %lld nonzeros (%.2f per node); basis: %lld nonzeros\n",
        static_cast<long long>(b.weights.nonZeros()),
        double(b.weights.nonZeros()) / std::max<Index>(1, b.weights.rows()),
        static_cast<long long>(b.basis.nonZeros()));
    std::printf("  PD: laplacian %lld nonzeros, reduced blocks %lld x %lld\n",
        static_cast<long long>(b.laplacian.nonZeros()),
        static_cast<long long>(b.reduced_laplacian.rows()),
        static_cast<long long>(b.reduced_laplacian.cols()));
    std::printf("  collision: %lld primitives, %lld (primitive, handle) bound terms, "
                "%lld (primitive, face) entries\n",
        static_cast<long long>(c.primitive_kind.size()),
        static_cast<long long>(c.bound_handles.size()),
        static_cast<long long>(c.face_primitives.size()));
}

} // namespace mat
