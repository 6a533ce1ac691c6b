#pragma once
// The Delaunay tetrahedralization of a point set (CGAL Delaunay_triangulation_3, Epick kernel),
// with plain Eigen types in and out. Every CGAL header stays in cgal_delaunay.cpp, a small
// translation unit apart from Mesh_3.

#include "common/eigen_types.hpp"

namespace mat {

/// The finite tetrahedra of the Delaunay triangulation of `points` (#P x 3, pairwise distinct,
/// finite), as #T x 4 point indices. Deterministic and independent of CGAL's internal order:
/// each row is sorted ascending and the rows are sorted lexicographically (so rows are not
/// oriented). Degenerate (co-spherical) configurations are resolved by CGAL's symbolic
/// perturbation, which depends only on the points. Throws mat::Error if fewer than 4 points are
/// given or all points lie in one plane.
MatX4i delaunay_tetrahedra(const Eigen::Ref<const MatX3>& points);

} // namespace mat
