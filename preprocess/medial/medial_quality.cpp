#include "preprocess/medial/medial_quality.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"
#include "preprocess/medial/surface_sampling.hpp"

namespace mat {
namespace {

    // Points spread evenly over the unit sphere (golden-angle spiral).
    std::vector<Vec3> fibonacci_directions(int count)
    {
        std::vector<Vec3> directions;
        const double golden = M_PI * (3.0 - std::sqrt(5.0));
        for (int i = 0; i < count; ++i) {
            const double z = 1.0 - (2.0 * i + 1.0) / count;
            const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
            directions.emplace_back(rho * std::cos(golden * i), rho * std::sin(golden * i), z);
        }
        return directions;
    }

    // Interpolated spheres (center, radius) from which the envelope is explored.
    std::vector<Vec4> ray_origins(const MedialMesh& medial)
    {
        std::vector<Vec4> origins;
        auto sphere = [&](Index s) {
            Vec4 m;
            m << medial.centers.row(s).transpose(), medial.radii(s);
            return m;
        };
        for (Index s = 0; s < medial.num_spheres(); ++s)
            origins.push_back(sphere(s));
        for (Index c = 0; c < medial.num_cones(); ++c)
            origins.push_back(0.5 * (sphere(medial.cones(c, 0)) + sphere(medial.cones(c, 1))));
        for (Index l = 0; l < medial.num_slabs(); ++l)
            origins.push_back((sphere(medial.slabs(l, 0)) + sphere(medial.slabs(l, 1))
                                  + sphere(medial.slabs(l, 2)))
                / 3.0);
        return origins;
    }

} // namespace

MedialFitMeasure measure_medial_fit(const MedialMesh& medial, const SurfaceMesh& surface,
    const SurfaceDistance& distance, Index surface_samples, int directions)
{
    MAT_CHECK(medial.num_spheres() > 0, "the medial mesh has no sphere");
    MAT_CHECK(directions > 0 && surface_samples > 0, "directions {} and samples {} must be > 0",
        directions, surface_samples);
    const MedialDistanceField field(medial);
    MedialFitMeasure measure;
    measure.bbox_diagonal = distance.bounds().diagonal().norm();

    // Surface -> envelope, and coverage: at the samples and every vertex.
    const SurfaceSamples samples = sample_surface(surface, surface_samples);
    MatX3 points(samples.points.rows() + surface.num_vertices(), 3);
    points << samples.points, surface.positions;
    const Index n = points.rows();
    VecX values(n);
    tbb::parallel_for(Index(0), n, [&](Index i) { values(i) = field(points.row(i).transpose()); });
    measure.surface_samples = n;
    Index worst_sample = 0;
    measure.surface_to_envelope = values.cwiseAbs().maxCoeff(&worst_sample);
    measure.worst_surface_point = points.row(worst_sample).transpose();
    measure.coverage = double((values.array() <= 0).count()) / double(n);

    // Envelope -> surface: march rays from interpolated sphere centers to the boundary.
    // At most about 200k rays: fewer directions per origin when there are many origins.
    const std::vector<Vec4> origins = ray_origins(medial);
    const int used_directions
        = std::clamp(static_cast<int>(200000 / std::max<std::size_t>(origins.size(), 1)),
            std::min(12, directions), directions);
    const std::vector<Vec3> rays = fibonacci_directions(used_directions);
    const double tolerance = 5e-5 * measure.bbox_diagonal;
    const double min_step = 1e-3 * measure.bbox_diagonal;
    std::vector<double> worst(origins.size(), 0.0);
    std::vector<Vec3> worst_point(origins.size(), Vec3::Zero());
    tbb::parallel_for(std::size_t(0), origins.size(), [&](std::size_t o) {
        const Vec3 center = origins[o].head<3>();
        double farthest = 0.0;
        for (const Vec3& u : rays) {
            // March while inside: each step the depth (the ball of that radius lies inside the
            // envelope), at least min_step; then bisect the last step down to the boundary.
            double inside = origins[o](3), s = inside;
            for (int step = 0; step < 400; ++step) {
                const double d = field(center + s * u);
                if (d > 0)
                    break;
                inside = s;
                s += std::max(-d, min_step);
            }
            double outside = s;
            for (int k = 0; k < 20 && outside - inside > tolerance; ++k) {
                const double middle = 0.5 * (inside + outside);
                (field(center + middle * u) > 0 ? outside : inside) = middle;
            }
            const Vec3 y = center + 0.5 * (inside + outside) * u;
            const double d = distance.unsigned_distance(y);
            if (d > farthest) {
                farthest = d;
                worst_point[o] = y;
            }
        }
        worst[o] = farthest;
    });
    measure.envelope_samples = static_cast<Index>(origins.size() * rays.size());
    const std::size_t worst_origin
        = static_cast<std::size_t>(std::max_element(worst.begin(), worst.end()) - worst.begin());
    measure.envelope_to_surface = worst[worst_origin];
    measure.worst_envelope_point = worst_point[worst_origin];
    measure.hausdorff = std::max(measure.surface_to_envelope, measure.envelope_to_surface);
    return measure;
}

} // namespace mat
