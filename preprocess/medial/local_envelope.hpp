#pragma once
// The primitives around one sphere of a medial mesh (the sphere, its cones and its slabs), for
// measuring exactly how far surface points are from the envelope they make (the kernels of
// common/medial_primitives). Ranks the final collapses of the simplification by the distance
// they really cause.

#include <array>
#include <vector>

#include "common/eigen_types.hpp"
#include "common/medial_primitives_kernels.hpp"

namespace mat {

class LocalEnvelope {
public:
    /// The central sphere (center, radius).
    explicit LocalEnvelope(const Vec4& sphere);

    /// A neighbor sphere (every corner of a cone or slab must be added once, first).
    void add_sphere(const Vec4& sphere);
    /// A cone from the central sphere to `other`.
    void add_cone(const Vec4& other);
    /// A slab of the central sphere and two others.
    void add_slab(const Vec4& first, const Vec4& second);
    /// Reserves room for the given numbers of primitives.
    void reserve(std::size_t spheres, std::size_t primitives);

    /// Exact signed distance from p to the union of the primitives (negative inside). Starts
    /// from the nearest sphere (an upper bound) and evaluates only the primitives whose cheap
    /// lower bounds can lower it, building their data on first use. Not thread-safe (one
    /// LocalEnvelope per thread).
    double signed_distance(const Vec3& p);

    /// The largest squared signed distance over the rows `ids` of `points` (#P x 3), or the
    /// first value found above `bound` (so that a caller comparing against `bound` can stop).
    /// With budget > 0, only the first `budget` ids and about `budget` more spread evenly over
    /// the rest are measured (callers put the likely worst first).
    double max_squared_distance(const Eigen::Ref<const MatX3>& points, const std::vector<int>& ids,
        double bound, std::size_t budget = 0);

    /// The squared signed distance at every row `ids` of `points` (#P x 3), into `out`.
    void squared_distances(const Eigen::Ref<const MatX3>& points, const std::vector<int>& ids,
        std::vector<double>& out);

private:
    /// A cone (count 2) or slab (count 3); corner 0 is the central sphere.
    struct Primitive {
        int count = 0;
        std::array<Vec3, 3> centers;
        std::array<double, 3> radii {};
        Vec3 centroid = Vec3::Zero();
        double reach = 0.0; ///< the ball (centroid, reach) holds the primitive
        bool ready = false;
        detail::PairData cone;
        detail::SlabData slab;
    };

    void add(int count, const Vec4& first, const Vec4& second);
    /// A lower bound of the primitive's signed distance at p.
    static double lower_bound(const Primitive& primitive, const Vec3& p);

    Vec3 m_center;
    double m_radius;
    std::vector<Vec4, Eigen::aligned_allocator<Vec4>> m_spheres; ///< the central one, neighbors
    std::vector<Primitive> m_primitives;
};

} // namespace mat
