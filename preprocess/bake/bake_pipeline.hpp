#pragma once
// The whole offline stage (docs/method.md, section 2): surface + medial mesh -> one BakeData,
// stage by stage, with a progress line per stage on a terminal and a table of time and peak
// memory.

#include <string>

#include "common/bake_data.hpp"
#include "common/timer.hpp"
#include "preprocess/bake/bake_inputs.hpp"
#include "preprocess/medial/medial_generator.hpp"
#include "preprocess/meshing/cgal_mesh3.hpp"

namespace mat {

struct BakeOptions {
    std::string surface; ///< closed surface file
    InputChecks checks; ///< what the input checks let through (--allow-self-intersections)
    std::string medial; ///< .ma file
    /// > 0: generate the medial mesh with this many spheres instead of reading `medial`
    Index spheres = 0;
    MedialGeneratorOptions generator; ///< used when spheres > 0 (its `spheres` is overridden)
    std::string output; ///< .h5 bake file
    /// Length unit of the input files (--unit): "mm", "cm", "m" or "in"; the bake is in metres.
    std::string unit = "m";
    double tet_size = k_default_tet_size; ///< tet size as a fraction of the bbox diagonal
    /// Bound on the vertices of the tet mesher's triangulation (docs/mat-bake.md, "Bounds").
    Index max_tet_vertices = 2000000;
    /// Perturb slivers after the refinement (--sliver-perturbation; docs/method.md, section 2,
    /// step 1): rounder tets for a longer meshing.
    bool perturb_slivers = true;
    std::string quadratic = "none"; ///< "all", "none" or a comma-separated list of handles
    int weights_per_node = 8; ///< K: largest weights kept per node
    double region_alpha = 0.5; ///< handle region: nodes within alpha * radius of the center
    /// mat-bake --error E (percent of the bbox diagonal): choose the spheres, quadratic handles and
    /// tet size (preprocess/model_size/); empty: bake as given. run_bake itself ignores it.
    std::string error;
};

/// Metres per `unit` of --unit: mm 0.001, cm 0.01, m 1, in 0.0254. Throws mat::Error for any
/// other unit.
double unit_scale(const std::string& unit);

/// Moves lengths in `unit` to metres (docs/mat-bake.md, "Units"): positions, or centers and
/// radii. mm and cm divide by 1000 and 100, so a length that is a whole number of mm gives the
/// same double as the same length written in metres.
void scale_to_metres(SurfaceMesh& surface, const std::string& unit);
void scale_to_metres(MedialMesh& medial, const std::string& unit);

/// What a bake measured, for the report and for tests.
struct BakeReport {
    StageReport stages;
    Index surface_vertices = 0, surface_faces = 0;
    Index medial_spheres = 0, medial_cones = 0, medial_slabs = 0;
    bool medial_generated = false;
    MedialQuality medial_quality; ///< when generated
    Index uncovered_vertices = 0;
    double max_outside = 0.0; ///< before inflation, absolute
    double inflation = 0.0; ///< added to every radius
    double bbox_diagonal = 0.0;
    Index tets = 0, nodes = 0;
    double min_dihedral_degrees = 0.0;
    Index surface_outside_tets = 0; ///< surface vertices outside the tet mesh
    Index medial_outside_tets = 0; ///< sphere centers outside the tet mesh
    double medial_max_outside_distance = 0.0;
    Index handles = 0, quadratic_handles = 0, columns = 0;
    /// Handles whose region was widened to a tet (handle_regions.hpp step 4, run only when the
    /// basis came out rank-deficient).
    Index handles_given_tets = 0;
    double weight_partition_error = 0.0, weight_min = 0.0, weight_max = 0.0;
    double weight_sparsify_change = 0.0;
    double linear_precision_error = 0.0; ///< relative, over random affine fields
    double quadratic_precision_error = -1.0; ///< relative, -1 if no node is fully quadratic
    double reduced_reciprocal_condition = 0.0;

    /// A readable multi-line summary (without the stage table).
    std::string summary() const;
};

/// Runs every stage and returns the bake; fills `report`. Throws mat::Error on bad input.
BakeData run_bake(const BakeOptions& options, BakeReport& report);

/// The same, with options.spheres > 0 and the medial mesh already generated for it: `generated`
/// stands for the generator's output (the model-size search bakes one sphere count many times).
BakeData run_bake(const BakeOptions& options, BakeReport& report, const MedialMesh* generated);

/// Parses --quadratic: "all", "none" or a list "0,4,7" of handle indices below num_handles.
Eigen::Matrix<bool, Eigen::Dynamic, 1> parse_quadratic(const std::string& text, Index num_handles);

} // namespace mat
