#pragma once
// Brute-force reference and checks for the primitive-pair tests: a dense grid of both parameter
// domains (its samples decide whether some f < 0), then, g = |c_a - c_b| - r_a - r_b being
// convex, a nested golden-section search over the weights of one primitive, each point of which
// is minimized exactly over the other primitive's weights by the library's point distance
// (common/medial_primitives, an implementation independent of primitive_pair). Random pairs of
// every kind.

#include <array>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include "common/eigen_types.hpp"
#include "runtime/collision/primitive_pair.hpp"

namespace mat::test {

#if defined(__SANITIZE_ADDRESS__)
constexpr int k_fewer = 5; // sanitizer builds run several times slower: fewer random cases
#else
constexpr int k_fewer = 1;
#endif

constexpr double k_infinity = std::numeric_limits<double>::infinity();

class Rng {
public:
    explicit Rng(unsigned seed)
        : m_gen(seed)
    {
    }
    double uniform(double lo = 0.0, double hi = 1.0)
    {
        return std::uniform_real_distribution<double>(lo, hi)(m_gen);
    }
    double normal() { return std::normal_distribution<double>()(m_gen); }
    int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(m_gen); }
    Vec3 box() { return Vec3(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)); }
    Vec3 unit() { return Vec3(normal(), normal(), normal()).normalized(); }

private:
    std::mt19937_64 m_gen;
};

using Weights = std::array<double, 3>;

/// f = |C|^2 - R^2 and g = |C| - R at weights, in the caller's coordinates.
struct Value {
    double g;
    double f;
};
Value value(const Primitive& a, const Weights& wa, const Primitive& b, const Weights& wb);

/// Scale of relative tolerances: the larger bounding-box diagonal of the two primitives (for
/// two points of zero radius, their distance).
double pair_size(const Primitive& a, const Primitive& b);

/// The best point found by brute force, and whether any sample had f < 0.
struct Reference {
    double g = k_infinity;
    Weights wa {}, wb {};
    bool f_negative = false;
};

/// The reference minimum of g over both primitives' weights.
Reference brute_force(const Primitive& a, const Primitive& b);

/// The primitive's spheres, for failure messages.
std::string describe(const Primitive& p);

/// Every property of the two functions on one pair; returns "" or what failed. `reference`
/// is min g found by brute force (and whether a sample had f < 0); `exact_g`, when finite, is
/// a closed-form min g.
std::string check_pair(const Primitive& a, const Primitive& b, const Reference& reference,
    double exact_g = k_infinity);

/// check_pair against brute_force(a, b).
std::string check_against_brute_force(
    const Primitive& a, const Primitive& b, double exact_g = k_infinity);

/// A random primitive: centers in [-spread, spread]^3, radii in [0, max_radius] drawn in one of
/// four modes (independent, equal, one large, some zero).
Primitive random_primitive(int count, Rng& rng, double spread, double max_radius);

/// Transforms every center by x -> scale x + shift and every radius by r -> scale r.
Primitive transformed(Primitive p, double scale, const Vec3& shift);

/// A random pair of the given kinds, b placed at a random offset so that about half the pairs
/// intersect.
std::pair<Primitive, Primitive> random_pair(int count_a, int count_b, Rng& rng);

/// "sphere", "cone" or "slab".
const char* kind_name(int count);

} // namespace mat::test
