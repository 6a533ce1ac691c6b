#include "runtime/collision/medial_bounds_kernels.hpp"

#include <cmath>

#include <Eigen/SVD>

namespace mat {

namespace {

    // Whether mu I - g is positive definite (LDL^T with positive pivots; g symmetric).
    bool shifted_positive_definite(const Mat3& g, double mu)
    {
        const double d0 = mu - g(0, 0);
        if (!(d0 > 0.0))
            return false;
        const double l10 = -g(1, 0) / d0;
        const double l20 = -g(2, 0) / d0;
        const double d1 = mu - g(1, 1) + l10 * g(1, 0);
        if (!(d1 > 0.0))
            return false;
        const double l21 = (-g(2, 1) + l20 * g(1, 0)) / d1;
        const double d2 = mu - g(2, 2) + l20 * g(2, 0) - l21 * l21 * d1;
        return d2 > 0.0;
    }

} // namespace

// Higham 1986 ("Computing the polar decomposition, with applications"), eq. 3.2 with the
// Frobenius-norm scaling of section 3.
Mat3 nearest_rotation(const Mat3& f)
{
    const double size = f.norm();
    bool converged = false;
    Mat3 x = f;
    if (size > 0.0 && f.determinant() > 1e-6 * size * size * size) {
        for (int iteration = 0; iteration < 16 && !converged; ++iteration) {
            // Columns of the cofactor matrix: X^T cof = det(X) I, so X^-T = cof / det.
            Mat3 cofactor;
            cofactor.col(0) = x.col(1).cross(x.col(2));
            cofactor.col(1) = x.col(2).cross(x.col(0));
            cofactor.col(2) = x.col(0).cross(x.col(1));
            const double det = x.col(0).dot(cofactor.col(0));
            if (!(det > 0.0))
                break;
            const Mat3 inverse_transpose = cofactor / det;
            const double gamma
                = std::sqrt(std::sqrt(inverse_transpose.squaredNorm() / x.squaredNorm()));
            const Mat3 next = 0.5 * (gamma * x + inverse_transpose / gamma);
            converged = (next - x).squaredNorm() <= 1e-20;
            x = next;
        }
    }
    if (!converged) {
        const Eigen::JacobiSVD<Mat3> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
        Mat3 u = svd.matrixU();
        if ((u * svd.matrixV().transpose()).determinant() < 0.0)
            u.col(2) = -u.col(2);
        x = u * svd.matrixV().transpose();
    }
    return Eigen::Quaterniond(x).normalized().toRotationMatrix();
}

double largest_eigenvalue_upper_bound(const Mat3& g)
{
    const double frobenius = g.norm();
    if (!(frobenius > 0.0))
        return 0.0;
    const double c2 = g.trace();
    const double c1 = g(0, 0) * g(1, 1) - g(0, 1) * g(0, 1) + g(0, 0) * g(2, 2) - g(0, 2) * g(0, 2)
        + g(1, 1) * g(2, 2) - g(1, 2) * g(1, 2);
    const double c0 = g.determinant();
    const auto polynomial
        = [&](double lambda) { return ((lambda - c2) * lambda + c1) * lambda - c0; };
    double lambda = frobenius;
    double value = polynomial(lambda);
    for (int iteration = 0; iteration < 64; ++iteration) {
        const double slope = (3.0 * lambda - 2.0 * c2) * lambda + c1;
        if (!(value > 0.0) || !(slope > 0.0))
            break;
        const double next = lambda - value / slope;
        const double next_value = polynomial(next);
        // p <= 0 means next crossed the root (rounding, mostly near a double root where p is
        // flat): keep the last iterate, which is above it.
        if (!(next_value > 0.0))
            break;
        const double step = lambda - next;
        lambda = next;
        value = next_value;
        if (step <= 1e-10 * lambda)
            break;
    }
    // Rounding can leave lambda a hair low: raise it until mu I - g factors.
    double margin = 1e-11 * lambda + 1e-13 * frobenius;
    for (int attempt = 0; attempt < 64; ++attempt, margin *= 4.0)
        if (shifted_positive_definite(g, lambda + margin))
            return (lambda + margin) * (1.0 + 1e-13);
    return frobenius; // >= lambda_max; not reached for a finite g
}

} // namespace mat
