#pragma once
// The initial medial mesh of a sampled surface: the inner part of the Voronoi diagram of the
// samples (Amenta et al. 2001; the input of Q-MAT, Li et al. 2015). Its spheres are the
// circumcenters of the Delaunay tetrahedra that lie inside the surface, its edges join the
// spheres of two such tetrahedra sharing a face (Voronoi edges), its triangles fan out the
// Voronoi faces (dual to Delaunay edges) whose every vertex is inside. Each sphere remembers the
// samples it touches (the vertices of its tetrahedra), from which the simplification's quadrics
// are built.

#include <array>
#include <vector>

#include "common/eigen_types.hpp"
#include "preprocess/medial/surface_distance.hpp"

namespace mat {

/// A medial complex under construction: spheres, edges (every edge, those of the triangles
/// included) and triangles, with per-sphere contact samples in compressed rows.
struct MedialComplex {
    MatX3 centers; ///< #S x 3
    VecX radii; ///< #S, > 0
    std::vector<std::array<int, 2>> edges; ///< sorted pairs, sorted, unique
    std::vector<std::array<int, 3>> triangles; ///< sorted triples, sorted, unique
    std::vector<int> contact_offsets; ///< #S + 1
    std::vector<int> contact_samples; ///< sample indices; sphere s owns [offsets[s], offsets[s+1])

    Index num_spheres() const { return centers.rows(); }
};

/// Builds the inner Voronoi complex of `samples` (#P x 3) from their Delaunay tetrahedra
/// (#T x 4, e.g. delaunay_tetrahedra()). A circumcenter is inside when its signed distance to
/// the surface is below -min_depth; its radius is that depth (so the sphere is inscribed).
/// Circumcenters of face-adjacent tetrahedra closer than 1e-9 x the bbox diagonal are merged.
/// Pieces of the complex separated by a few outer tetrahedra (thin parts, sharp edges) are
/// joined by edges whose middle lies inside.
/// Deterministic. The result may be empty (no circumcenter inside).
MedialComplex inner_voronoi_complex(const Eigen::Ref<const MatX3>& samples,
    const Eigen::Ref<const MatX4i>& tets, const SurfaceDistance& surface, double min_depth);

} // namespace mat
