#pragma once
// The checks of a bake's inputs, in the one code path that `mat-bake check`, `mat-bake medial`
// and the bake share (docs/mat-bake.md, "Checks"), so that check accepts exactly what the bake
// accepts and both refuse with the same line: the surface must be closed, manifold, outward and
// free of self-intersections (unless allowed), every sphere center of a medial mesh inside it.

#include <string>

#include "common/mesh_types.hpp"
#include "formats/surface_validation.hpp"

namespace mat {

struct InputChecks {
    /// --allow-self-intersections: bake a surface whose faces intersect (with a warning).
    bool allow_self_intersections = false;
};

/// A surface as read (in its file's units) and what the checks found.
struct CheckedSurface {
    SurfaceMesh surface;
    /// validate_surface(), and for a closed manifold the exact self-intersection test.
    SurfaceReport report;
};

/// Reads `path` and inspects it; refuses nothing itself (see require_bake_surface).
CheckedSurface inspect_surface(const std::string& path);

/// Throws mat::Error with one line naming `path`, the problem and an example if the bake cannot
/// use the surface: not a closed, outward manifold (require_closed_manifold()), or faces that
/// intersect while checks.allow_self_intersections is off. Logs a warning when they are allowed.
void require_bake_surface(
    const CheckedSurface& checked, const std::string& path, const InputChecks& checks);

/// Throws mat::Error with one line if the bake cannot use the medial mesh read from
/// `medial_path`: no sphere, or a sphere center outside `surface` (same units as the medial mesh).
void require_bake_medial(const MedialMesh& medial, const std::string& medial_path,
    const SurfaceMesh& surface, const std::string& surface_path);

} // namespace mat
