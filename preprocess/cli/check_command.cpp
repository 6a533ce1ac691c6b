#include "preprocess/cli/check_command.hpp"

#include <cstdio>
#include <string>

#include "common/log.hpp"
#include "common/medial_primitives.hpp"
#include "common/timer.hpp"
#include "formats/medial_io.hpp"
#include "preprocess/bake/bake_inputs.hpp"

namespace mat {

CLI::App* add_check_command(CLI::App& app, CheckOptions& options)
{
    CLI::App* check = app.add_subcommand("check",
        "Read and validate a surface and a medial mesh as the bake does (it refuses what the "
        "bake refuses, with the same line), print what was read");
    check->add_option("surface", options.surface, "Closed surface (OBJ, PLY, STL, OFF, glTF, ...)")
        ->required()
        ->check(CLI::ExistingFile);
    check->add_option("--medial", options.medial, "Medial mesh (.ma, Q-MAT or the paper's dialect)")
        ->check(CLI::ExistingFile);
    add_input_check_options(*check, options.checks);
    return check;
}

void add_input_check_options(CLI::App& command, InputChecks& checks)
{
    command.add_flag("--allow-self-intersections", checks.allow_self_intersections,
        "Go on with a surface whose faces intersect (refused by default; the tets then fill what "
        "lies inside an odd number of its sheets)");
}

namespace {

    // How well the medial mesh covers the surface: signed distance of every surface vertex to
    // the envelope (> 0: outside every primitive).
    void print_coverage(
        const MedialMesh& medial, const CheckedSurface& checked, const std::string& medial_path)
    {
        const SurfaceMesh& surface = checked.surface;
        const MedialDistanceField field(medial);
        Index outside = 0;
        double worst = -1e300;
        for (Index v = 0; v < surface.num_vertices(); ++v) {
            const double d = field(surface.positions.row(v).transpose());
            outside += d > 0 ? 1 : 0;
            worst = std::max(worst, d);
        }
        const double diagonal = checked.report.bbox.diagonal().norm();
        std::printf("%s: coverage: %lld of %lld surface vertices outside every primitive "
                    "(%.2f%%), max distance outside %.3g (%.3f%% of the bbox diagonal)\n",
            medial_path.c_str(), static_cast<long long>(outside),
            static_cast<long long>(surface.num_vertices()),
            100.0 * outside / std::max<Index>(1, surface.num_vertices()), std::max(worst, 0.0),
            100.0 * std::max(worst, 0.0) / diagonal);
    }

} // namespace

void run_check(const CheckOptions& options)
{
    Timer timer;
    const CheckedSurface checked = inspect_surface(options.surface);
    std::string summary = checked.report.summary(options.surface);
    if (!summary.empty() && summary.back() != '\n')
        summary += '\n';
    std::fputs(summary.c_str(), stdout);
    logger().debug("read and checked {} in {:.3f} s", options.surface, timer.seconds());

    MedialMesh medial;
    if (!options.medial.empty()) {
        medial = read_medial(options.medial);
        std::printf("%s: %lld spheres, %lld cones, %lld slabs, radii in [%.6g, %.6g]\n",
            options.medial.c_str(), static_cast<long long>(medial.num_spheres()),
            static_cast<long long>(medial.num_cones()), static_cast<long long>(medial.num_slabs()),
            medial.radii.size() ? medial.radii.minCoeff() : 0.0,
            medial.radii.size() ? medial.radii.maxCoeff() : 0.0);
        if (checked.report.is_closed_manifold())
            print_coverage(medial, checked, options.medial);
    }
    // The bake's own refusals, in its order (bake_inputs.hpp).
    require_bake_surface(checked, options.surface, options.checks);
    if (!options.medial.empty())
        require_bake_medial(medial, options.medial, checked.surface, options.surface);
}

} // namespace mat
