#include "preprocess/samples/sample_generator.hpp"

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/medial_primitives.hpp"
#include "common/timer.hpp"
#include "formats/medial_io.hpp"
#include "formats/surface_io.hpp"
#include "preprocess/meshing/cgal_mesh3.hpp"

namespace mat {
namespace {

    /// Accumulates spheres, cones and slabs.
    class MedialBuilder {
    public:
        int sphere(const Vec3& center, double radius)
        {
            m_centers.push_back(center);
            m_radii.push_back(radius);
            return static_cast<int>(m_centers.size()) - 1;
        }
        void cone(int a, int b) { m_cones.emplace_back(a, b); }
        void slab(int a, int b, int c) { m_slabs.emplace_back(a, b, c); }

        MedialMesh build() const
        {
            MedialMesh mesh;
            mesh.centers.resize(static_cast<Index>(m_centers.size()), 3);
            mesh.radii.resize(static_cast<Index>(m_radii.size()));
            for (std::size_t i = 0; i < m_centers.size(); ++i) {
                mesh.centers.row(static_cast<Index>(i)) = m_centers[i].transpose();
                mesh.radii(static_cast<Index>(i)) = m_radii[i];
            }
            mesh.cones.resize(static_cast<Index>(m_cones.size()), 2);
            for (std::size_t i = 0; i < m_cones.size(); ++i)
                mesh.cones.row(static_cast<Index>(i)) << m_cones[i].first, m_cones[i].second;
            mesh.slabs.resize(static_cast<Index>(m_slabs.size()), 3);
            for (std::size_t i = 0; i < m_slabs.size(); ++i)
                mesh.slabs.row(static_cast<Index>(i)) << std::get<0>(m_slabs[i]),
                    std::get<1>(m_slabs[i]), std::get<2>(m_slabs[i]);
            return mesh;
        }

    private:
        std::vector<Vec3> m_centers;
        std::vector<double> m_radii;
        std::vector<std::pair<int, int>> m_cones;
        std::vector<std::tuple<int, int, int>> m_slabs;
    };

    /// A tapered capsule: one cone, 0.7 m long.
    MedialMesh capsule()
    {
        MedialBuilder builder;
        builder.cone(
            builder.sphere(Vec3(-0.25, 0, 0), 0.12), builder.sphere(Vec3(0.25, 0, 0), 0.08));
        return builder.build();
    }

    /// A rounded box 0.76 x 0.36 x 0.16 m: its medial axis is a rectangle, 2 slabs of equal
    /// radius.
    MedialMesh rounded_bar()
    {
        MedialBuilder builder;
        const double r = 0.08;
        const int a = builder.sphere(Vec3(-0.3, -0.1, 0), r);
        const int b = builder.sphere(Vec3(0.3, -0.1, 0), r);
        const int c = builder.sphere(Vec3(0.3, 0.1, 0), r);
        const int d = builder.sphere(Vec3(-0.3, 0.1, 0), r);
        builder.slab(a, b, c);
        builder.slab(a, c, d);
        return builder.build();
    }

    /// A ring of 16 cones: spheres of radius 0.08 m on a circle of radius 0.3 m.
    MedialMesh torus()
    {
        MedialBuilder builder;
        const int count = 16;
        for (int i = 0; i < count; ++i) {
            const double angle = 2.0 * M_PI * i / count;
            builder.sphere(0.3 * Vec3(std::cos(angle), std::sin(angle), 0.0), 0.08);
        }
        for (int i = 0; i < count; ++i)
            builder.cone(i, (i + 1) % count);
        return builder.build();
    }

    /// A starfish-like creature about 1 m across: a domed body of slabs (a fan around a thick
    /// center sphere) and 6 limbs, chains of cones of decreasing radius that curl in 3D, some
    /// up into a spiral, some sideways, one down.
    MedialMesh creature(int detail)
    {
        const int num_limbs = 6;
        const int segments = 4 * detail + 2;
        const double body_radius = 0.16;
        const double limb_length = 0.42;
        const double base_radius = 0.055, tip_radius = 0.016;
        // Per limb: total curl (radians, about the limb's side axis: > 0 curls up), sideways
        // tilt of the curl axis, and the droop of its first direction.
        const double curl[num_limbs] = { 5.5, 1.8, 4.2, -1.2, 3.2, 1.2 };
        const double tilt[num_limbs] = { 0.2, -0.8, 0.5, 0.0, -0.4, 1.0 };
        const double droop[num_limbs] = { -0.15, 0.0, -0.1, 0.1, 0.0, -0.05 };

        MedialBuilder builder;
        const int center = builder.sphere(Vec3(0, 0, 0.02), 0.09);
        // The body ring: a limb root at every other sphere, a thinner sphere between roots.
        std::vector<int> ring;
        std::vector<Vec3> roots;
        for (int i = 0; i < 2 * num_limbs; ++i) {
            const double angle = M_PI * i / num_limbs;
            const bool root = i % 2 == 0;
            const double distance = root ? body_radius : 0.8 * body_radius;
            const Vec3 position(distance * std::cos(angle), distance * std::sin(angle), 0.0);
            ring.push_back(builder.sphere(position, root ? 0.06 : 0.045));
            if (root)
                roots.push_back(position);
        }
        for (int i = 0; i < 2 * num_limbs; ++i)
            builder.slab(center, ring[static_cast<std::size_t>(i)],
                ring[static_cast<std::size_t>((i + 1) % (2 * num_limbs))]);

        // Curvature grows toward the tip (weight (s/L)^1.5), so curled limbs end in a spiral.
        std::vector<double> weights(static_cast<std::size_t>(segments));
        double weight_sum = 0.0;
        for (int j = 0; j < segments; ++j) {
            weights[static_cast<std::size_t>(j)] = std::pow((j + 0.5) / segments, 1.5);
            weight_sum += weights[static_cast<std::size_t>(j)];
        }
        const double step = limb_length / segments;
        for (int l = 0; l < num_limbs; ++l) {
            const double angle = 2.0 * M_PI * l / num_limbs;
            const Vec3 radial(std::cos(angle), std::sin(angle), 0.0);
            const Vec3 side(-std::sin(angle), std::cos(angle), 0.0);
            // Rotating the radial direction about -side turns it up (+z).
            const Vec3 axis = (-side + tilt[l] * Vec3::UnitZ()).normalized();
            Vec3 tangent = Eigen::AngleAxisd(droop[l], -side) * radial;
            Vec3 position = roots[static_cast<std::size_t>(l)];
            int previous = ring[static_cast<std::size_t>(2 * l)];
            for (int j = 0; j < segments; ++j) {
                const double turn = curl[l] * weights[static_cast<std::size_t>(j)] / weight_sum;
                // Half the turn before the step and half after: the midpoint rule.
                tangent = Eigen::AngleAxisd(0.5 * turn, axis) * tangent;
                position += step * tangent;
                tangent = Eigen::AngleAxisd(0.5 * turn, axis) * tangent;
                const double s = double(j + 1) / segments;
                const double radius = base_radius + (tip_radius - base_radius) * std::pow(s, 0.8);
                const int sphere = builder.sphere(position, radius);
                builder.cone(previous, sphere);
                previous = sphere;
            }
        }
        return builder.build();
    }

    struct SampleKind {
        std::function<MedialMesh(int)> medial;
        double default_facet_size; ///< fraction of the bbox diagonal
    };

    const std::map<std::string, SampleKind>& sample_kinds()
    {
        static const std::map<std::string, SampleKind> kinds = {
            { "capsule", { [](int) { return capsule(); }, 0.03 } },
            { "creature", { creature, 0.01 } },
            { "rounded_bar", { [](int) { return rounded_bar(); }, 0.03 } },
            { "torus", { [](int) { return torus(); }, 0.025 } },
        };
        return kinds;
    }

    const SampleKind& sample_kind(const std::string& name)
    {
        const auto& kinds = sample_kinds();
        const auto it = kinds.find(name);
        if (it == kinds.end()) {
            std::string known;
            for (const auto& [known_name, kind] : kinds)
                known += (known.empty() ? "" : ", ") + known_name;
            throw_error("unknown sample '{}' (known samples: {})", name, known);
        }
        return it->second;
    }

} // namespace

std::vector<std::string> list_samples()
{
    std::vector<std::string> names;
    for (const auto& [name, kind] : sample_kinds())
        names.push_back(name);
    return names;
}

MedialMesh make_sample_medial(const std::string& name, int detail)
{
    const SampleKind& kind = sample_kind(name);
    if (detail < 1 || detail > 5)
        throw_error("sample '{}': detail must be 1 to 5, got {}", name, detail);
    return kind.medial(detail);
}

Sample make_sample(const std::string& name, const SampleOptions& options)
{
    const SampleKind& kind = sample_kind(name);
    const double facet_fraction
        = options.facet_size == 0.0 ? kind.default_facet_size : options.facet_size;
    if (!(facet_fraction > 0.0 && facet_fraction <= 0.2))
        throw_error("sample '{}': facet size must lie in (0, 0.2] of the bounding-box diagonal, "
                    "got {}",
            name, facet_fraction);

    Timer timer;
    Sample sample;
    sample.name = name;
    sample.medial = make_sample_medial(name, options.detail);
    const MedialDistanceField field(sample.medial);
    const Box3 envelope = field.bounds();
    const double diagonal = envelope.diagonal().norm();
    // Padded so that the function is positive on the boundary of the meshing box.
    const Box3 bounds(envelope.min() - Vec3::Constant(0.05 * diagonal),
        envelope.max() + Vec3::Constant(0.05 * diagonal));

    ImplicitSurfaceOptions surface_options;
    surface_options.facet_size = facet_fraction * diagonal;
    surface_options.facet_distance = 0.1 * facet_fraction * diagonal;
    surface_options.facet_angle = 30.0;
    surface_options.interior_points = sample.medial.centers;
    sample.surface = mesh_implicit_surface(
        [&field](const Vec3& p) { return field(p); }, bounds, surface_options);
    logger().info("sample {}: {} spheres, {} cones, {} slabs; surface of {} triangles in {:.2f} s",
        name, sample.medial.num_spheres(), sample.medial.num_cones(), sample.medial.num_slabs(),
        sample.surface.num_faces(), timer.seconds());
    return sample;
}

void write_sample(const Sample& sample, const std::string& directory)
{
    std::error_code error;
    std::filesystem::create_directories(directory, error);
    if (error)
        throw_error("{}: cannot create the directory: {}", directory, error.message());
    const std::filesystem::path base = std::filesystem::path(directory) / sample.name;
    write_surface(base.string() + ".obj", sample.surface);
    write_medial(base.string() + ".ma", sample.medial, MedialDialect::qmat);
}

} // namespace mat
