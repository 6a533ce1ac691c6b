#include "runtime/collision/medial_bounds.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <unistd.h>

#include <tbb/task_arena.h>

#include "common/error.hpp"
#include "preprocess/bake/bake_pipeline.hpp"
#include "preprocess/collision/bound_data.hpp"
#include "tests/support/error_checks.hpp"
#include "tests/support/medial_bounds_checks.hpp"

namespace mat {
namespace {
    using test::affine_q;
    using test::count_outside;

    // A unit cube whose faces are split into n x n squares (two triangles each), as OBJ text.
    std::string subdivided_cube_obj(int n)
    {
        std::map<std::array<int, 3>, int> index;
        std::string vertices;
        std::string faces;
        auto vertex = [&](std::array<int, 3> g) {
            const auto [it, inserted] = index.emplace(g, static_cast<int>(index.size()) + 1);
            if (inserted)
                vertices += fmt::format(
                    "v {} {} {}\n", double(g[0]) / n, double(g[1]) / n, double(g[2]) / n);
            return it->second;
        };
        for (int axis = 0; axis < 3; ++axis)
            for (int side = 0; side <= n; side += n) {
                const int u = (axis + 1) % 3;
                const int v = (axis + 2) % 3;
                for (int i = 0; i < n; ++i)
                    for (int j = 0; j < n; ++j) {
                        std::array<int, 4> quad;
                        const int corners[4][2]
                            = { { i, j }, { i + 1, j }, { i + 1, j + 1 }, { i, j + 1 } };
                        for (int c = 0; c < 4; ++c) {
                            std::array<int, 3> g;
                            g[axis] = side;
                            g[u] = corners[c][0];
                            g[v] = corners[c][1];
                            quad[c] = vertex(g);
                        }
                        if (side == 0)
                            std::swap(quad[1], quad[3]); // outward normal -axis
                        faces += fmt::format("f {} {} {}\nf {} {} {}\n", quad[0], quad[1], quad[2],
                            quad[0], quad[2], quad[3]);
                    }
            }
        return vertices + faces;
    }

    // Q-MAT medial mesh of the cube: a slab (0 1 2), a cone (2 3) and a lone sphere (4).
    const char* const cube_medial = "5 4 1\n"
                                    "v 0.3 0.3 0.35 0.2\n"
                                    "v 0.7 0.3 0.35 0.2\n"
                                    "v 0.5 0.7 0.35 0.2\n"
                                    "v 0.5 0.5 0.75 0.2\n"
                                    "v 0.8 0.8 0.8 0.12\n"
                                    "e 0 1\ne 1 2\ne 0 2\ne 2 3\n"
                                    "f 0 1 2\n";

    // The subdivided cube baked once with the medial mesh above, handles 1 and 3 quadratic.
    const BakeData& cube_bake()
    {
        static const BakeData bake = [] {
            const std::filesystem::path dir = std::filesystem::temp_directory_path()
                / fmt::format("mat_medial_bounds_test_{}", ::getpid());
            std::filesystem::create_directories(dir);
            std::ofstream(dir / "cube.obj") << subdivided_cube_obj(8);
            std::ofstream(dir / "cube.ma") << cube_medial;
            BakeOptions options;
            options.surface = (dir / "cube.obj").string();
            options.medial = (dir / "cube.ma").string();
            options.tet_size = 0.15;
            options.quadratic = "1,3";
            BakeReport report;
            BakeData result = run_bake(options, report);
            std::filesystem::remove_all(dir);
            return result;
        }();
        return bake;
    }

    // Surface vertex positions #Vs x 3 for q: nodes x = X + B q, interpolated in their tets.
    MatX3 surface_positions(const BakeData& bake, const MatX3& q)
    {
        const MatX3 nodes = bake.tet_mesh.positions + bake.basis * q;
        MatX3 out = MatX3::Zero(bake.surface.num_vertices(), 3);
        for (Index v = 0; v < out.rows(); ++v)
            for (int k = 0; k < 4; ++k)
                out.row(v) += bake.surface_barycentric(v, k)
                    * nodes.row(bake.tet_mesh.tets(bake.surface_tet(v), k));
        return out;
    }

    Mat3 random_rotation(std::mt19937& rng, double max_angle)
    {
        std::normal_distribution<double> normal;
        std::uniform_real_distribution<double> angle(0.0, max_angle);
        const Vec3 axis = Vec3(normal(rng), normal(rng), normal(rng)).normalized();
        return Eigen::AngleAxisd(angle(rng), axis).toRotationMatrix();
    }

    TEST(MedialBounds, RestShapeHasNoIncrement)
    {
        const BakeData& bake = cube_bake();
        MedialBounds bounds(bake);
        ASSERT_EQ(bounds.num_primitives(), bake.collision.primitive_kind.size());
        // The cube's medial mesh gives every kind of primitive.
        for (int kind = 0; kind < 3; ++kind)
            EXPECT_TRUE((bake.collision.primitive_kind.array() == kind).any()) << kind;
        EXPECT_TRUE((bake.handle_quadratic.array() == 1).any());
        EXPECT_TRUE((bake.handle_quadratic.array() == 0).any());

        for (RadiusUpdate mode : { RadiusUpdate::bound, RadiusUpdate::bound_without_rigid_removal,
                 RadiusUpdate::lazy }) {
            bounds.update(MatX3::Zero(bake.num_columns(), 3), mode);
            EXPECT_EQ(bounds.increments().cwiseAbs().maxCoeff(), 0.0);
            for (Index p = 0; p < bounds.num_primitives(); ++p)
                for (int i = 0; i < bounds.counts()(p); ++i) {
                    const int s = bake.collision.primitive_spheres(p, i);
                    EXPECT_EQ(bounds.radii()(p, i), bake.medial.radii(s));
                    EXPECT_EQ((bounds.sphere(p, i).center - bake.medial.centers.row(s).transpose())
                                  .norm(),
                        0.0);
                }
        }
        EXPECT_EQ(count_outside(bounds, bake, bake.surface.positions, 1e-12), 0);
        bounds.update_from_positions(bake.surface.positions, bake.medial.centers);
        EXPECT_EQ(bounds.increments().maxCoeff(), 0.0);
    }

    TEST(MedialBounds, EveryHandleWithWeightOnAPrimitiveIsCounted)
    {
        // The bound needs a term for every handle whose basis functions are nonzero at a vertex
        // of the primitive or at one of its spheres.
        const BakeData& bake = cube_bake();
        const MedialCollisionData& collision = bake.collision;
        const SparseRowMatrix surface_basis = interpolate_rows(
            bake.basis, bake.tet_mesh.tets, bake.surface_tet, bake.surface_barycentric);
        VecXi column_handle(bake.num_columns());
        for (Index j = 0; j < bake.num_handles(); ++j)
            column_handle
                .segment(bake.handle_column_offsets(j),
                    bake.handle_column_offsets(j + 1) - bake.handle_column_offsets(j))
                .setConstant(static_cast<int>(j));
        auto counted = [&](Index p, int handle) {
            for (int e = collision.bound_indptr(p); e < collision.bound_indptr(p + 1); ++e)
                if (collision.bound_handles(e) == handle)
                    return true;
            return false;
        };
        int checked = 0;
        for (Index v = 0; v < bake.surface.num_vertices(); ++v)
            for (SparseRowMatrix::InnerIterator it(surface_basis, v); it; ++it, ++checked)
                EXPECT_TRUE(counted(collision.vertex_primitive(v), column_handle(it.col())))
                    << "vertex " << v << " handle " << column_handle(it.col());
        for (Index p = 0; p < collision.primitive_kind.size(); ++p)
            for (int i = 0; i < 3 && collision.primitive_spheres(p, i) >= 0; ++i)
                for (SparseRowMatrix::InnerIterator it(
                         bake.medial_basis, collision.primitive_spheres(p, i));
                     it; ++it, ++checked)
                    EXPECT_TRUE(counted(p, column_handle(it.col())));
        EXPECT_GT(checked, 0);
    }

    // 20 random q: 5 rigid motions of the whole body, then 15 ever larger per-handle affine and
    // quadratic perturbations on top of a random rigid motion.
    TEST(MedialBounds, EnlargedPrimitivesEncloseTheirVerticesForRandomQ)
    {
        const BakeData& bake = cube_bake();
        MedialBounds bounds(bake);
        const double length = 1.0; // the cube's edge
        const double tolerance = 1e-12 * length; // rounding of the positions
        std::mt19937 rng(20240611);
        std::normal_distribution<double> normal;
        int lazy_misses_large = 0;
        for (int c = 0; c < 20; ++c) {
            const Mat3 rotation = random_rotation(rng, EIGEN_PI);
            const Vec3 translation(normal(rng), normal(rng), normal(rng));
            MatX3 q = affine_q(bake, rotation - Mat3::Identity(), translation);
            const double amplitude = c < 5 ? 0.0 : 0.04 * (c - 4);
            for (Index j = 0; j < bake.num_handles(); ++j) {
                const int offset = bake.handle_column_offsets(j);
                const int terms = bake.handle_column_offsets(j + 1) - offset;
                for (int term = 0; term < terms; ++term)
                    for (int d = 0; d < 3; ++d)
                        q(offset + term, d) += amplitude * normal(rng)
                            * (term == 0 ? length : bake.handle_scales(j));
            }
            const MatX3 positions = surface_positions(bake, q);
            const MatX3 centers = bake.medial.centers + bake.medial_basis * q;

            bounds.update(q, RadiusUpdate::bound);
            EXPECT_LE((bounds.sphere_centers() - centers).cwiseAbs().maxCoeff(), 1e-14);
            EXPECT_EQ(count_outside(bounds, bake, positions, tolerance), 0) << "case " << c;
            const VecX bound = bounds.increments();
            bounds.update(q, RadiusUpdate::bound_without_rigid_removal);
            EXPECT_EQ(count_outside(bounds, bake, positions, tolerance), 0) << "case " << c;
            const VecX raw = bounds.increments();
            bounds.update(q, RadiusUpdate::lazy);
            EXPECT_EQ(bounds.increments().maxCoeff(), 0.0);
            const int lazy_misses = count_outside(bounds, bake, positions, tolerance);
            bounds.update_from_positions(positions, centers);
            EXPECT_EQ(count_outside(bounds, bake, positions, tolerance), 0) << "case " << c;
            const VecX exact = bounds.increments();

            // The exact increment is the least one for the vertices: no valid bound is below.
            for (Index p = 0; p < bounds.num_primitives(); ++p) {
                EXPECT_LE(exact(p), bound(p) + tolerance) << "case " << c << " primitive " << p;
                EXPECT_LE(exact(p), raw(p) + tolerance) << "case " << c << " primitive " << p;
            }
            std::printf("case %2d amplitude %.2f: sum of increments: bound %.4g, without rigid "
                        "removal %.4g, exact for the vertices %.4g; lazy misses %d of %d\n",
                c, amplitude, bound.sum(), raw.sum(), exact.sum(), lazy_misses,
                static_cast<int>(positions.rows()));
            if (c < 5) {
                EXPECT_LE(bound.maxCoeff(), 1e-9 * length) << "rigid case " << c;
                EXPECT_EQ(lazy_misses, 0) << "rigid case " << c;
            }
            EXPECT_LT(bound.sum(), raw.sum()) << "case " << c;
            if (amplitude >= 0.3)
                lazy_misses_large += lazy_misses;
        }
        EXPECT_GT(lazy_misses_large, 0);
    }

    TEST(MedialBounds, CoveredFacesLieInsideEveryPrimitiveThatListsThem)
    {
        // With cover_faces(), the exact update holds each triangle listed under a primitive,
        // corners and inner points, so an intersection of two triangles lies in two primitives
        // that list them. Without it only the primitive's own vertices are held: a triangle whose
        // corners belong to different primitives sticks out, at rest already.
        const BakeData& bake = cube_bake();
        const MedialCollisionData& collision = bake.collision;
        const double tolerance = 1e-12; // the cube's edge is 1
        // Corners, edge midpoints and the centroid of face f at `positions`.
        const auto face_points = [&](const MatX3& positions, Index f) {
            std::vector<Vec3> points;
            const Vec3 a = positions.row(bake.surface.faces(f, 0)).transpose();
            const Vec3 b = positions.row(bake.surface.faces(f, 1)).transpose();
            const Vec3 c = positions.row(bake.surface.faces(f, 2)).transpose();
            for (const Vec3& x : { a, b, c, Vec3(0.5 * (a + b)), Vec3(0.5 * (b + c)),
                     Vec3(0.5 * (a + c)), Vec3((a + b + c) / 3.0) })
                points.push_back(x);
            return points;
        };
        const auto count_sticking_out = [&](const MedialBounds& bounds, const MatX3& positions) {
            int out = 0;
            for (Index p = 0; p < bounds.num_primitives(); ++p)
                for (int i = collision.face_primitives_indptr(p);
                     i < collision.face_primitives_indptr(p + 1); ++i)
                    for (const Vec3& x : face_points(positions, collision.face_primitives(i)))
                        out += test::primitive_contains(bounds, p, x, tolerance) ? 0 : 1;
            return out;
        };
        MedialBounds vertices_only(bake);
        vertices_only.update_from_positions(bake.surface.positions, bake.medial.centers);
        EXPECT_GT(count_sticking_out(vertices_only, bake.surface.positions), 0);

        MedialBounds covered(bake);
        covered.cover_faces(collision, bake.surface.faces, bake.surface.positions);
        std::mt19937 rng(7);
        std::normal_distribution<double> normal;
        for (int c = 0; c < 8; ++c) {
            MatX3 q = affine_q(bake, random_rotation(rng, EIGEN_PI) - Mat3::Identity(),
                Vec3(normal(rng), normal(rng), normal(rng)));
            for (Index row = 0; row < q.rows(); ++row)
                for (int d = 0; d < 3; ++d)
                    q(row, d) += 0.05 * c * normal(rng);
            const MatX3 positions = surface_positions(bake, q);
            covered.update_from_positions(positions, bake.medial.centers + bake.medial_basis * q);
            EXPECT_EQ(count_sticking_out(covered, positions), 0) << "case " << c;
            EXPECT_EQ(count_outside(covered, bake, positions, tolerance), 0) << "case " << c;
        }
        // A second call gives the same increments; at rest the corners of other primitives
        // stick out of a primitive, so the covered increments are not all 0 there.
        const MatX3 rest = surface_positions(bake, MatX3::Zero(bake.num_columns(), 3));
        covered.update_from_positions(rest, bake.medial.centers);
        const VecX at_rest = covered.increments();
        covered.cover_faces(collision, bake.surface.faces, bake.surface.positions);
        covered.update_from_positions(rest, bake.medial.centers);
        EXPECT_EQ(covered.increments(), at_rest);
        EXPECT_GT(at_rest.maxCoeff(), 0.0);
        EXPECT_THROW(
            covered.cover_faces(collision, bake.surface.faces, bake.surface.positions.topRows(3)),
            Error);
    }

    TEST(MedialBounds, SameResultForAnyThreadCount)
    {
        const BakeData& bake = cube_bake();
        std::mt19937 rng(7);
        std::normal_distribution<double> normal;
        MatX3 q = affine_q(bake, random_rotation(rng, EIGEN_PI) - Mat3::Identity(), Vec3(1, 2, 3));
        for (Index i = 0; i < q.size(); ++i)
            q.data()[i] += 0.2 * normal(rng);
        MedialBounds many(bake);
        MedialBounds one(bake);
        many.update(q);
        tbb::task_arena arena(1);
        arena.execute([&] { one.update(q); });
        EXPECT_TRUE((many.centers().array() == one.centers().array()).all());
        EXPECT_TRUE((many.radii().array() == one.radii().array()).all());
        EXPECT_TRUE((many.boxes().array() == one.boxes().array()).all());
        // Boxes enclose the spheres.
        for (Index p = 0; p < many.num_primitives(); ++p)
            for (int i = 0; i < many.counts()(p); ++i) {
                const MedialSphere sphere = many.sphere(p, i);
                EXPECT_TRUE(many.box(p).contains(sphere.bounds()));
            }
    }

    TEST(MedialBounds, BadInputThrows)
    {
        const BakeData& bake = cube_bake();
        MedialBounds bounds(bake);
        test::expect_error_containing(
            [&] { bounds.update(MatX3::Zero(bake.num_columns() + 1, 3)); }, { "q has", "rows" });
        MatX3 q = MatX3::Zero(bake.num_columns(), 3);
        q(3, 1) = std::nan("");
        test::expect_error_containing([&] { bounds.update(q); }, { "row 3 of q" });
        test::expect_error_containing(
            [&] { bounds.update_from_positions(MatX3::Zero(2, 3), bake.medial.centers); },
            { "surface positions" });

        MedialCollisionData collision = bake.collision;
        collision.bound_handles(1) = 99;
        test::expect_error_containing(
            [&] {
                MedialBounds(bake.medial, collision, bake.medial_basis, bake.handle_centers,
                    bake.handle_scales, bake.handle_column_offsets);
            },
            { "bound entry 1", "handle 99" });
        collision = bake.collision;
        collision.vertex_primitive(5) = -1;
        test::expect_error_containing(
            [&] {
                MedialBounds(bake.medial, collision, bake.medial_basis, bake.handle_centers,
                    bake.handle_scales, bake.handle_column_offsets);
            },
            { "surface vertex 5" });
        collision = bake.collision;
        collision.primitive_spheres(0, 1) = 1000;
        test::expect_error_containing(
            [&] {
                MedialBounds(bake.medial, collision, bake.medial_basis, bake.handle_centers,
                    bake.handle_scales, bake.handle_column_offsets);
            },
            { "primitive 0", "1000" });
    }

} // namespace
} // namespace mat
