#include "preprocess/cli/check_command.hpp"

#include <cstdio>
#include <string>

#include "common/log.hpp"
#include "common/medial_primitives.hpp"
#include "common/timer.hpp"
#include "formats/medial_io.hpp"
#include "formats/surface_io.hpp"
#include "formats/surface_validation.hpp"

namespace mat {

CLI::App* add_check_command(CLI::App& app, CheckOptions& options)
{
    CLI::App* check = app.add_subcommand("check",
        "Read and validate a surface and a medial mesh, "
        "print what was read");
    check->add_option("surface", options.surface, "Closed surface (OBJ, PLY, STL, OFF, glTF, ...)")
        ->required()
        ->check(CLI::ExistingFile);
    check->add_option("--medial", options.medial, "Medial mesh (.ma, Q-MAT or the paper's dialect)")
        ->check(CLI::ExistingFile);
    return check;
}

void run_check(const CheckOptions& options)
{
    Timer timer;
    const SurfaceMesh surface = read_surface(options.surface);
    const SurfaceReport report = validate_surface(surface);
    std::string summary = report.summary(options.surface);
    if (!summary.empty() && summary.back() != '\n')
        summary += '\n';
    std::fputs(summary.c_str(), stdout);
    logger().debug("read {} in {:.3f} s", options.surface, timer.seconds());

    if (!options.medial.empty()) {
        const MedialMesh medial = read_medial(options.medial);
        std::printf("%s: %lld spheres, %lld cones, %lld slabs, radii in [%.6g, %.6g]\n",
            options.medial.c_str(), static_cast<long long>(medial.num_spheres()),
            static_cast<long long>(medial.num_cones()), static_cast<long long>(medial.num_slabs()),
            medial.radii.size() ? medial.radii.minCoeff() : 0.0,
            medial.radii.size() ? medial.radii.maxCoeff() : 0.0);
        if (report.is_closed_manifold()) {
            // How well the medial mesh covers the surface: signed distance of every surface
            // vertex to the envelope (> 0: outside every primitive).
            const MedialDistanceField field(medial);
            Index outside = 0;
            double worst = -1e300;
            for (Index v = 0; v < surface.num_vertices(); ++v) {
                const double d = field(surface.positions.row(v).transpose());
                outside += d > 0 ? 1 : 0;
                worst = std::max(worst, d);
            }
            const double diagonal = report.bbox.diagonal().norm();
            std::printf("%s: coverage: %lld of %lld surface vertices outside every primitive "
                        "(%.2f%%), max distance outside %.3g (%.3f%% of the bbox diagonal)\n",
                options.medial.c_str(), static_cast<long long>(outside),
                static_cast<long long>(surface.num_vertices()),
                100.0 * outside / std::max<Index>(1, surface.num_vertices()), std::max(worst, 0.0),
                100.0 * std::max(worst, 0.0) / diagonal);
        }
    }
    require_closed_manifold(report, options.surface);
}

} // namespace mat
