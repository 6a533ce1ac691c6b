#pragma once
// The 3 x 3 kernels of the medial bounds (runtime/collision/medial_bounds.hpp): the rotation
// of a handle's transform, and sigma_max^2 of a handle's coefficients as a certified upper bound.

#include "common/eigen_types.hpp"

namespace mat {

/// The rotation closest to `f` (the R of the polar decomposition f = R S, det R = +1), by
/// Higham's scaled Newton iteration when det f > 0 and f is not near singular, by an SVD
/// otherwise (an inverted f gets the nearest proper rotation). Always a rotation to rounding: the
/// result goes through a unit quaternion.
Mat3 nearest_rotation(const Mat3& f);

/// An upper bound of the largest eigenvalue of the symmetric positive semidefinite `gram`,
/// within about 1e-8 of it (relative), 1e-4 when the largest eigenvalue is nearly
/// double or triple (where the polynomial is flat and its rounding larger), also in
/// floating point: Newton's method on the characteristic polynomial p from the Frobenius norm (>=
/// lambda_max; above lambda_max, p is increasing and convex, so the iterates decrease monotonically
/// towards it), then a margin raised until mu I - gram has a positive LDL^T factorization. 0 for
/// the zero matrix.
double largest_eigenvalue_upper_bound(const Mat3& gram);

} // namespace mat
