#pragma once
// Checks that a triangle surface bounds a solid: closed, manifold, consistently and outward
// oriented, free of degenerate faces and non-finite coordinates. Pure geometry and topology,
// O(F log F); the report gives, per problem class, a count and one example element.

#include <string>

#include "common/mesh_types.hpp"

namespace mat {

/// One class of problem: how often it occurs and one example element.
struct SurfaceIssue {
    Index count = 0; ///< number of offending elements (edges, vertices, faces or components)
    Index example = -1; ///< index of the example element (its kind depends on the class), or -1
    std::string description; ///< the example in words, e.g. "edge (4, 9) of face 17"

    explicit operator bool() const { return count > 0; }
};

/// What validate_surface() found. Blocking classes make a surface unusable as a solid boundary;
/// several components and unreferenced vertices are reported but allowed.
struct SurfaceReport {
    Index num_vertices = 0;
    Index num_faces = 0;
    Box3 bbox; ///< over the finite vertices; empty if there are none
    double signed_volume = 0.0; ///< sum over all valid faces; > 0 for an outward closed surface
    Index num_components = 0; ///< faces connected through shared edges

    // Blocking, in the order require_closed_manifold() reports them.
    SurfaceIssue invalid_indices; ///< faces with an index outside [0, #V); example: face
    SurfaceIssue non_finite; ///< vertices with a NaN or infinite coordinate; example: vertex
    SurfaceIssue boundary_edges; ///< edges with one face ("not closed"); example: face
    SurfaceIssue non_manifold_edges; ///< edges with more than two faces; example: face
    SurfaceIssue non_manifold_vertices; ///< vertices whose faces form several fans; example: vertex
    SurfaceIssue inconsistent_orientation; ///< edges used twice in one direction; example: face
    SurfaceIssue inward_orientation; ///< closed components facing inward; example: component
    SurfaceIssue degenerate_faces; ///< repeated index or (near-)zero area; example: face

    // Not blocking.
    SurfaceIssue components; ///< count = #components when there are several; example: component
    SurfaceIssue unreferenced_vertices; ///< vertices no face uses; example: vertex

    /// Pairs of faces that intersect. validate_surface() does not look for them: mat-bake's
    /// exact test (preprocess/bake/bake_inputs.hpp) fills this in for a closed manifold and sets
    /// self_intersections_tested; example: the pair's first face, described with the second.
    SurfaceIssue self_intersections;
    bool self_intersections_tested = false;

    /// True if no blocking class occurs and there is at least one face.
    bool is_closed_manifold() const;

    /// Several lines for `mat-bake check`: sizes, bbox, volume, then one line per class (and
    /// one for the self-intersections when they were looked for).
    std::string summary(const std::string& file) const;
};

/// Validates `mesh`. A face is degenerate if it repeats an index or its area is at most
/// `relative_area_tolerance` x (bbox diagonal)^2. A closed component is inward if its signed
/// volume has the wrong sign for its nesting depth: positive for outer shells, negative for
/// cavities (components enclosed by an odd number of others). Never throws on bad input.
SurfaceReport validate_surface(const SurfaceMesh& mesh, double relative_area_tolerance = 1e-12);

/// Throws mat::Error with one line naming `file`, the first blocking class, its count and its
/// example, e.g. "bunny.obj: not closed: 12 boundary edges, e.g. edge (4, 9) of face 17".
void require_closed_manifold(const SurfaceReport& report, const std::string& file);

} // namespace mat
