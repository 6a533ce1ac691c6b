#pragma once
// Where to start meshing a level set: short segments that cross the zero set of an implicit
// function, found on a grid and along rays from known interior points. Mesh_3 bisects them
// into its initial surface points (its own random ray shooting never ends when the level set
// is empty, and may miss thin parts).

#include <functional>
#include <vector>

#include "common/eigen_types.hpp"

namespace mat {

/// A segment whose end points have opposite signs: f(inside) < 0 < f(outside).
struct SignChange {
    Vec3 inside;
    Vec3 outside;
};

/// Sign changes of f (negative inside) found
///  - on the edges of a regular grid over `bounds` of spacing about `spacing` (at most
///    `max_cells` cells per axis), keeping the first crossing edge (in scan order) of each block
///    of 2 x 2 x 2 cells, so that the seeds are spread about 2 spacings apart;
///  - along the 6 axis rays from each of `interior_points` (#P x 3), marching in steps of
///    spacing / 2 to the first point where f > 0 (points where f >= 0 are skipped).
/// f is evaluated in parallel (TBB) and must be safe to call concurrently; the result does not
/// depend on the thread count.
std::vector<SignChange> find_sign_changes(const std::function<double(const Vec3&)>& f,
    const Box3& bounds, double spacing, const Eigen::Ref<const MatX3>& interior_points,
    int max_cells = 64);

/// Greedy thinning in input order: keeps a point if no kept point lies closer than
/// `min_distance`. Returns the indices of the kept points, ascending.
/// points  #P x 3
std::vector<int> thin_out_points(const Eigen::Ref<const MatX3>& points, double min_distance);

} // namespace mat
