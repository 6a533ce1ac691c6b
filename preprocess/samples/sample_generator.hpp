#pragma once
// Sample assets with EXACT medial meshes: each sample defines a medial mesh and meshes the
// boundary of its envelope (the union of its primitives), so the medial mesh is exact for the
// surface by construction. Sizes are in meters.

#include <string>
#include <vector>

#include "common/mesh_types.hpp"

namespace mat {

struct SampleOptions {
    /// Facet size of the surface as a fraction of the bounding-box diagonal; 0 picks the
    /// sample's default: 0.03 (capsule, rounded_bar: 1.2k-1.7k triangles), 0.025 (torus: 2k),
    /// 0.01 (creature: 7.7k triangles, fine enough to tetrahedralize into 2k-50k tets).
    double facet_size = 0.0;
    /// Creature only: 1 to 5. Limbs are chains of 4 d + 2 cones: 49, 73, 97, 121 or 145 spheres.
    int detail = 2;
};

/// A generated sample: its medial mesh and the surface of the medial mesh's envelope.
struct Sample {
    std::string name;
    MedialMesh medial;
    SurfaceMesh surface; ///< closed, manifold, outward; vertices on the envelope to ~1e-8 m
};

/// The names make_sample() accepts: capsule, rounded_bar, torus, creature.
std::vector<std::string> list_samples();

/// The medial mesh of a sample alone (cheap: no surface meshing).
/// Throws mat::Error on an unknown name (listing the known ones) or a detail outside [1, 5].
MedialMesh make_sample_medial(const std::string& name, int detail = 2);

/// The medial mesh and its envelope surface (CGAL Mesh_3 on the envelope's signed distance,
/// vertices projected onto the zero set). Deterministic.
/// Throws mat::Error on an unknown name, a detail outside [1, 5] or a facet size outside
/// (0, 0.2].
Sample make_sample(const std::string& name, const SampleOptions& options = {});

/// Writes DIRECTORY/NAME.obj (the surface) and DIRECTORY/NAME.ma (the medial mesh, Q-MAT
/// dialect), each atomically; creates the directory if needed. Throws mat::Error on failure.
void write_sample(const Sample& sample, const std::string& directory);

} // namespace mat
