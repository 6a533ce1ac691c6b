#pragma once
// The monomials of a handle's local coordinates y = (x - c_j) / s_j (docs/method.md, section 2,
// steps 3 and 5), in the one order the bake's basis columns and the runtime's products share.

#include "common/host_device.hpp"

namespace mat {

/// Columns per linear handle: 1, y1, y2, y3.
inline constexpr int linear_handle_terms = 4;
/// Columns per quadratic handle: the linear ones, then y1^2, y2^2, y3^2, y1 y2, y2 y3, y1 y3.
inline constexpr int quadratic_handle_terms = 10;

/// The factors of the quadratic monomials, axes counted from 0: p[4 + k] = y[a] y[b] with
/// a = quadratic_monomial_first[k], b = quadratic_monomial_second[k], k = 0..5.
inline constexpr int quadratic_monomial_first[6] = { 0, 1, 2, 0, 1, 0 };
inline constexpr int quadratic_monomial_second[6] = { 0, 1, 2, 1, 2, 2 };

/// Writes the monomials of y = (y1, y2, y3) in basis column order (BasisTerm in
/// preprocess/basis/handle_basis.hpp):
///   p[0] = 1,       p[1] = y1,      p[2] = y2,      p[3] = y3,
///   p[4] = y1 y1,   p[5] = y2 y2,   p[6] = y3 y3,
///   p[7] = y1 y2,   p[8] = y2 y3,   p[9] = y1 y3.
/// A linear handle uses p[0 .. 4), a quadratic one all ten.
MAT_HD void handle_monomials(double y1, double y2, double y3, double (&p)[quadratic_handle_terms])
{
    p[0] = 1.0;
    p[1] = y1;
    p[2] = y2;
    p[3] = y3;
    p[4] = y1 * y1;
    p[5] = y2 * y2;
    p[6] = y3 * y3;
    p[7] = y1 * y2;
    p[8] = y2 * y3;
    p[9] = y1 * y3;
}

} // namespace mat
