#pragma once
// Models for the runtime tests: a structured grid with the complete (identity) basis, built
// without the bake, and the shipped cube baked with a given medial mesh.

#include <string>

#include "common/bake_data.hpp"
#include "tests/support/grid_tets.hpp"

namespace mat::test {

/// A BakeData for the grid of `options` with its tet mesh and PD data (Dm^-1, volumes, lumped
/// masses, Laplacian) filled; no basis.
BakeData make_grid_bake(const GridTetOptions& options);

/// A BakeData for the grid of `options` whose basis is the identity (every node its own handle):
/// basis = I (n x n), reduced_laplacian = L, reduced_mass = M. Only the fields the runtime reads
/// are filled.
BakeData make_identity_bake(const GridTetOptions& options);

/// The shipped unit cube (tests/data/bake/cube.obj) baked with the medial mesh at `medial_path`
/// (tet size 0.15 of the diagonal); "" means the shipped cube.ma.
BakeData bake_cube(const std::string& medial_path = "", const std::string& quadratic = "none");

/// The cube bake with the shipped medial mesh, made once.
const BakeData& shipped_cube_bake();

} // namespace mat::test
