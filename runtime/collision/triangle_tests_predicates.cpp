// Exact orientation predicates (declared in triangle_tests.hpp).
//
// A determinant is first evaluated in doubles; its sign is returned when |det| exceeds the
// forward error bound of that evaluation (Shewchuk 1997, "Adaptive precision floating-point
// arithmetic and fast robust geometric predicates", the static bounds ccwerrboundA and
// o3derrboundA). Otherwise it is evaluated exactly as an expansion: a sum of doubles, sorted by
// increasing magnitude, that do not overlap, so that its sign is the sign of its largest
// component. Expansions are built with error-free transformations (Shewchuk section 2): two-sum
// (a + b = x + y exactly) and two-product (a * b = x + y exactly, with one fma). The file is
// compiled with -ffp-contract=off: contracting a + b * c into an fma would change the roundings
// the error bounds assume.

#include <algorithm>
#include <array>
#include <cmath>

#include "runtime/collision/triangle_tests.hpp"

namespace mat {

namespace {

    // Half an ulp of 1: the relative rounding error of one operation.
    constexpr double epsilon = 0x1p-53;
    // Shewchuk's bounds on the error of the double evaluations below, relative to the permanent
    // (the same expression with absolute values).
    constexpr double orient2d_bound = (3.0 + 16.0 * epsilon) * epsilon;
    constexpr double orient3d_bound = (7.0 + 56.0 * epsilon) * epsilon;

    // x + y = a + b exactly, with x = fl(a + b) (Knuth's two-sum, no precondition on |a|, |b|).
    inline void two_sum(double a, double b, double& x, double& y)
    {
        x = a + b;
        const double b_virtual = x - a;
        const double a_virtual = x - b_virtual;
        y = (a - a_virtual) + (b - b_virtual);
    }

    // x + y = a * b exactly, with x = fl(a * b).
    inline void two_product(double a, double b, double& x, double& y)
    {
        x = a * b;
        y = std::fma(a, b, -x);
    }

    // A non-overlapping expansion with components in increasing magnitude and no zeros (zero is
    // the empty expansion). 192 components hold the largest intermediate of orient3d. Only the
    // first n components are ever read or copied.
    struct Expansion {
        std::array<double, 192> c;
        int n = 0;

        Expansion() = default;
        Expansion(const Expansion& other) { *this = other; }
        Expansion& operator=(const Expansion& other)
        {
            n = other.n;
            std::copy(other.c.begin(), other.c.begin() + n, c.begin());
            return *this;
        }

        double operator[](int i) const { return c[static_cast<std::size_t>(i)]; }
        void push(double v)
        {
            if (v != 0.0)
                c[static_cast<std::size_t>(n++)] = v;
        }
        int sign() const { return n == 0 ? 0 : ((*this)[n - 1] > 0 ? 1 : -1); }
    };

    // h += b, in place (Shewchuk's GROW-EXPANSION with zero elimination: component i is read
    // before anything is written at an index above i, so the output may overwrite the input).
    void grow(Expansion& h, double b)
    {
        const int count = h.n;
        h.n = 0;
        double q = b;
        for (int i = 0; i < count; ++i) {
            double sum = 0.0;
            double err = 0.0;
            two_sum(q, h[i], sum, err);
            h.push(err);
            q = sum;
        }
        h.push(q);
    }

    // h += f (EXPANSION-SUM: grow by each component of f).
    void add(Expansion& h, const Expansion& f)
    {
        for (int i = 0; i < f.n; ++i)
            grow(h, f[i]);
    }

    // h = e * b (SCALE-EXPANSION with zero elimination); h must not be e.
    void scale(const Expansion& e, double b, Expansion& h)
    {
        h.n = 0;
        if (e.n == 0 || b == 0.0)
            return;
        double q = 0.0;
        double err = 0.0;
        two_product(e[0], b, q, err);
        h.push(err);
        for (int i = 1; i < e.n; ++i) {
            double product = 0.0;
            double product_err = 0.0;
            two_product(e[i], b, product, product_err);
            double sum = 0.0;
            two_sum(q, product_err, sum, err);
            h.push(err);
            two_sum(product, sum, q, err);
            h.push(err);
        }
        h.push(q);
    }

    // e * f.
    Expansion multiply(const Expansion& e, const Expansion& f)
    {
        Expansion h;
        Expansion term;
        for (int i = 0; i < f.n; ++i) {
            scale(e, f[i], term);
            add(h, term);
        }
        return h;
    }

    // a - b exactly, as an expansion of at most 2 components.
    Expansion difference(double a, double b)
    {
        double x = 0.0;
        double y = 0.0;
        two_sum(a, -b, x, y);
        Expansion e;
        e.push(y);
        e.push(x);
        return e;
    }

    // e1 * f1 - e2 * f2 exactly.
    Expansion cross_term(
        const Expansion& e1, const Expansion& f1, const Expansion& e2, const Expansion& f2)
    {
        Expansion h = multiply(e1, f1);
        Expansion p2 = multiply(e2, f2);
        for (int i = 0; i < p2.n; ++i)
            p2.c[static_cast<std::size_t>(i)] = -p2[i];
        add(h, p2);
        return h;
    }

    int orient2d_exact(const Vec2& a, const Vec2& b, const Vec2& c)
    {
        const Expansion acx = difference(a.x(), c.x());
        const Expansion acy = difference(a.y(), c.y());
        const Expansion bcx = difference(b.x(), c.x());
        const Expansion bcy = difference(b.y(), c.y());
        return cross_term(acx, bcy, acy, bcx).sign();
    }

    int orient3d_exact(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d)
    {
        std::array<Expansion, 3> ad;
        std::array<Expansion, 3> bd;
        std::array<Expansion, 3> cd;
        for (int k = 0; k < 3; ++k) {
            ad[static_cast<std::size_t>(k)] = difference(a[k], d[k]);
            bd[static_cast<std::size_t>(k)] = difference(b[k], d[k]);
            cd[static_cast<std::size_t>(k)] = difference(c[k], d[k]);
        }
        // det = adz (bdx cdy - cdx bdy) + bdz (cdx ady - adx cdy) + cdz (adx bdy - bdx ady).
        Expansion det = multiply(cross_term(bd[0], cd[1], cd[0], bd[1]), ad[2]);
        add(det, multiply(cross_term(cd[0], ad[1], ad[0], cd[1]), bd[2]));
        add(det, multiply(cross_term(ad[0], bd[1], bd[0], ad[1]), cd[2]));
        return det.sign();
    }

} // namespace

int orient2d(const Vec2& a, const Vec2& b, const Vec2& c)
{
    const double left = (a.x() - c.x()) * (b.y() - c.y());
    const double right = (a.y() - c.y()) * (b.x() - c.x());
    const double det = left - right;
    const double bound = orient2d_bound * (std::abs(left) + std::abs(right));
    if (det > bound)
        return 1;
    if (-det > bound)
        return -1;
    return orient2d_exact(a, b, c);
}

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d)
{
    const double adx = a.x() - d.x(), ady = a.y() - d.y(), adz = a.z() - d.z();
    const double bdx = b.x() - d.x(), bdy = b.y() - d.y(), bdz = b.z() - d.z();
    const double cdx = c.x() - d.x(), cdy = c.y() - d.y(), cdz = c.z() - d.z();
    const double bdx_cdy = bdx * cdy, cdx_bdy = cdx * bdy;
    const double cdx_ady = cdx * ady, adx_cdy = adx * cdy;
    const double adx_bdy = adx * bdy, bdx_ady = bdx * ady;
    const double det
        = adz * (bdx_cdy - cdx_bdy) + bdz * (cdx_ady - adx_cdy) + cdz * (adx_bdy - bdx_ady);
    const double permanent = (std::abs(bdx_cdy) + std::abs(cdx_bdy)) * std::abs(adz)
        + (std::abs(cdx_ady) + std::abs(adx_cdy)) * std::abs(bdz)
        + (std::abs(adx_bdy) + std::abs(bdx_ady)) * std::abs(cdz);
    const double bound = orient3d_bound * permanent;
    if (det > bound)
        return 1;
    if (-det > bound)
        return -1;
    return orient3d_exact(a, b, c, d);
}

} // namespace mat
