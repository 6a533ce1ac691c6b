#pragma once
// mat-bake --error E: the smallest model whose error against the full-space model stays within E
// on the standard load cases (load_cases.hpp). It chooses, in this order:
//   1. the tet size: coarsened geometrically from the finest (the user's --tet-size) while the
//      full-space model stays within tet_error_share x E of the full-space reference at the
//      finest size;
//   2. the number of spheres (generated medial mesh): doubled from first_spheres until the linear
//      reduced model is within E, then bisected;
//   3. quadratic handles: at sphere counts that failed, the handles with the largest local-step
//      residual (model_error.hpp) become quadratic, if that is within E with fewer reduced DOF
//      than the linear answer. With a fixed medial mesh, only this step and the tet size apply.
// The smallest model has the fewest reduced DOF, then the fewest tets. The error of a candidate
// is the largest, over the load cases, surface-vertex distance to the reference (% of the
// bounding-box diagonal); the RMS distance is reported too.

#include <string>
#include <vector>

#include "common/bake_data.hpp"
#include "preprocess/bake/bake_pipeline.hpp"
#include "preprocess/model_size/load_cases.hpp"
#include "preprocess/model_size/model_error.hpp"

namespace mat {

struct ModelSizeOptions {
    double error_percent = 0.0; ///< E: largest surface error allowed, % of the bbox diagonal
    /// The user's bake: surface; medial (fixed spheres) or none (generated, spheres = the largest
    /// count tried, 0 for max_spheres); tet_size = the finest (the reference's). quadratic is
    /// ignored.
    BakeOptions bake;
    Index first_spheres = 4; ///< the smallest generated sphere count tried
    Index max_spheres = 256; ///< the largest, unless bake.spheres is set
    double tet_growth = 1.5; ///< tet size factor between tet-size candidates, > 1
    double max_tet_size = 0.12; ///< coarsest tet size tried, fraction of the diagonal
    double tet_error_share = 1.0 / 3.0; ///< share of E the tet coarsening may spend
    double deflection = 0.1; ///< the gravity cases' reference deflection, fraction of diagonal
    StaticSolveOptions solve;
};

/// One model the search measured.
struct ModelCandidate {
    std::string stage; ///< reference, tet size, spheres, quadratic
    bool full_space = false;
    Index spheres = 0, quadratic = 0;
    double tet_size = 0.0;
    Index tets = 0;
    Index dof = 0; ///< reduced DOF (3 x basis columns); for full space 3 x nodes
    SurfaceError error; ///< each the largest over the load cases
    bool within = false;
    double seconds = 0.0;
};

struct ModelSizeResult {
    BakeData bake; ///< the chosen model's bake
    BakeReport report; ///< its bake report
    ModelCandidate chosen;
    std::string quadratic; ///< its quadratic handles, as --quadratic takes them
    std::vector<ModelCandidate> tried; ///< every candidate, in the order tried
    std::vector<LoadCase> cases; ///< with the calibrated gravity

    /// Every candidate tried, one row each, then the chosen one.
    std::string table() const;
};

/// Parses --error: a positive percentage of the bbox diagonal, "2" or "2%". Throws mat::Error.
double parse_error_percent(const std::string& text);

/// Runs the search. Throws mat::Error on bad input or if no candidate is within E.
ModelSizeResult choose_model_size(const ModelSizeOptions& options);

} // namespace mat
