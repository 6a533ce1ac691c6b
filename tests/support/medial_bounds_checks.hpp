#pragma once
// Shared by the medial-bounds test and benchmark: affine reduced coordinates and the count of
// surface vertices outside their enlarged primitive.

#include "common/bake_data.hpp"
#include "common/medial_primitives.hpp"
#include "runtime/collision/medial_bounds.hpp"

namespace mat::test {

/// Coefficients (k x 3) of the displacement u(x) = A x + t: handle j gets constant A c_j + t
/// and linear columns s_j A.
inline MatX3 affine_q(const BakeData& bake, const Mat3& a, const Vec3& t)
{
    MatX3 q = MatX3::Zero(bake.num_columns(), 3);
    for (Index j = 0; j < bake.num_handles(); ++j) {
        const int offset = bake.handle_column_offsets(j);
        q.row(offset) = (a * bake.handle_centers.row(j).transpose() + t).transpose();
        for (int d = 0; d < 3; ++d)
            q.row(offset + 1 + d) = bake.handle_scales(j) * a.col(d).transpose();
    }
    return q;
}

/// Whether x lies in primitive p of `bounds` (enlarged, deformed), within `tolerance`.
inline bool primitive_contains(const MedialBounds& bounds, Index p, const Vec3& x, double tolerance)
{
    switch (bounds.counts()(p)) {
    case 1:
        return bounds.sphere(p, 0).contains(x, tolerance);
    case 2:
        return MedialCone(bounds.sphere(p, 0), bounds.sphere(p, 1)).contains(x, tolerance);
    default:
        return MedialSlab(bounds.sphere(p, 0), bounds.sphere(p, 1), bounds.sphere(p, 2))
            .contains(x, tolerance);
    }
}

/// How many surface vertices (`positions`  #Vs x 3) lie outside their enlarged, deformed
/// primitive (the one they are assigned to) by more than `tolerance`.
inline int count_outside(
    const MedialBounds& bounds, const BakeData& bake, const MatX3& positions, double tolerance)
{
    int outside = 0;
    for (Index v = 0; v < positions.rows(); ++v)
        outside += primitive_contains(bounds, bake.collision.vertex_primitive(v),
                       positions.row(v).transpose(), tolerance)
            ? 0
            : 1;
    return outside;
}

} // namespace mat::test
