// What the HDF5 fuzz targets check (tests/fuzz/hdf5_checks.hpp).

#include "tests/fuzz/hdf5_checks.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"
#include "formats/bake_io.hpp"
#include "formats/trajectory_io.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace mat::fuzz {

namespace {
    template <typename Derived> bool indices_below(const Eigen::DenseBase<Derived>& a, Index limit)
    {
        return a.size() == 0 || (a.minCoeff() >= 0 && a.maxCoeff() < limit);
    }

    template <typename Sparse> bool finite_sparse(const Sparse& m)
    {
        for (Index k = 0; k < m.nonZeros(); ++k)
            if (!std::isfinite(m.valuePtr()[k]))
                return false;
        return true;
    }

    void check_bake(const BakeData& b, const char* target)
    {
        const auto check = [target](bool condition, const char* what) {
            mat::fuzz::check(condition, target, what);
        };
        const Index n = b.tet_mesh.positions.rows();
        const Index tets = b.tet_mesh.tets.rows();
        const Index spheres = b.medial.centers.rows();
        const Index m = b.handle_centers.rows();
        const Index k = b.basis.cols();
        check(indices_below(b.tet_mesh.tets, n), "tets index nodes");
        check(b.dm_inverse.rows() == tets && b.dm_inverse.cols() == 9, "dm_inverse T x 9");
        check(b.rest_volumes.size() == tets && b.lumped_mass.size() == n, "volumes and masses");
        check(indices_below(b.surface.faces, b.surface.positions.rows()), "faces index vertices");
        check(indices_below(b.surface_tet, tets), "surface tets in range");
        check(indices_below(b.medial.cones, spheres) && indices_below(b.medial.slabs, spheres),
            "medial primitives index spheres");
        check(b.medial.radii.size() == spheres, "one radius per sphere");
        check(b.weights.rows() == n && b.weights.cols() == m, "weights n x m");
        check(b.basis.rows() == n && b.medial_basis.rows() == spheres && b.medial_basis.cols() == k,
            "basis shapes");
        check(b.handle_column_offsets.size() == m + 1 && b.handle_column_offsets(m) == k,
            "column offsets end at k");
        check(b.laplacian.rows() == n && b.laplacian.cols() == n, "laplacian n x n");
        check(b.reduced_laplacian.rows() == k && b.reduced_mass.cols() == k, "reduced k x k");
        const MedialCollisionData& c = b.collision;
        const Index primitives = c.primitive_kind.size();
        check(c.face_primitives_indptr.size() == primitives + 1
                && c.bound_indptr.size() == primitives + 1,
            "collision indptr sizes");
        check(indices_below(c.bound_handles, m), "bound handles in range");
        check(b.tet_mesh.positions.allFinite() && b.dm_inverse.allFinite()
                && b.surface.positions.allFinite() && b.surface_barycentric.allFinite()
                && b.medial.centers.allFinite() && b.medial_barycentric.allFinite()
                && b.handle_centers.allFinite() && b.handle_scales.allFinite()
                && b.reduced_laplacian.allFinite() && b.reduced_mass.allFinite()
                && c.vertex_parameter.allFinite() && c.bound_factors.allFinite()
                && std::isfinite(b.medial_inflation),
            "finite numbers");
        check(finite_sparse(b.weights) && finite_sparse(b.basis) && finite_sparse(b.medial_basis)
                && finite_sparse(b.laplacian),
            "finite sparse values");
        check((tets == 0 || b.rest_volumes.minCoeff() > 0.0)
                && (n == 0 || b.lumped_mass.minCoeff() > 0.0),
            "positive volumes and masses");
        check(spheres == 0 || b.medial.radii.minCoeff() > 0.0, "positive radii");
        check(m == 0 || b.handle_scales.minCoeff() > 0.0, "positive handle scales");
    }
} // namespace

void read_and_check_bake(const std::string& path, const char* target)
{
    BakeData bake;
    try {
        bake = read_bake(path);
    } catch (const Error&) {
        return;
    }
    check_bake(bake, target);
}

void read_and_check_trajectory(const std::string& path, const char* target)
{
    const auto check
        = [target](bool condition, const char* what) { mat::fuzz::check(condition, target, what); };
    try {
        const TrajectoryReader in(path);
        (void)in.options();
        const Index frames = std::min<Index>(in.frame_count(), 64);
        for (Index object = 0; object < in.object_count(); ++object) {
            const Index vertices = in.vertex_count(object);
            check(vertices >= 1, "objects have vertices");
            check(indices_below(in.faces(object), vertices), "faces index vertices");
            check(in.rest_positions(object).rows() == vertices, "rest positions #V x 3");
            for (Index frame = 0; frame < frames; ++frame) {
                check(in.positions(object, frame).rows() == vertices, "positions #V x 3");
                if (in.has_velocities())
                    check(in.velocities(object, frame).rows() == vertices, "velocities #V x 3");
            }
        }
    } catch (const Error&) {
    }
}

} // namespace mat::fuzz
