#include "preprocess/collision/bound_data.hpp"

#include <algorithm>
#include <limits>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "common/medial_primitives.hpp"

namespace mat {

namespace {

    struct Primitive {
        PrimitiveKind kind;
        std::array<int, 3> spheres;
        Box3 box;
    };

    std::vector<Primitive> list_primitives(const MedialMesh& medial)
    {
        std::vector<Primitive> primitives;
        std::vector<char> used(static_cast<size_t>(medial.num_spheres()), 0);
        for (Index c = 0; c < medial.num_cones(); ++c) {
            const MedialCone cone = MedialCone::from_mesh(medial, c);
            primitives.push_back({ PrimitiveKind::cone,
                { medial.cones(c, 0), medial.cones(c, 1), -1 }, cone.bounds() });
            used[static_cast<size_t>(medial.cones(c, 0))]
                = used[static_cast<size_t>(medial.cones(c, 1))] = 1;
        }
        for (Index s = 0; s < medial.num_slabs(); ++s) {
            const MedialSlab slab = MedialSlab::from_mesh(medial, s);
            primitives.push_back({ PrimitiveKind::slab,
                { medial.slabs(s, 0), medial.slabs(s, 1), medial.slabs(s, 2) }, slab.bounds() });
            for (int k = 0; k < 3; ++k)
                used[static_cast<size_t>(medial.slabs(s, k))] = 1;
        }
        for (Index v = 0; v < medial.num_spheres(); ++v)
            if (!used[static_cast<size_t>(v)])
                primitives.push_back({ PrimitiveKind::sphere, { static_cast<int>(v), -1, -1 },
                    MedialSphere::from_mesh(medial, v).bounds() });
        return primitives;
    }

    // min over the primitive's spheres of |p - c(t)| - r(t), with the sphere weights t.
    std::pair<double, Vec3> sphere_distance(
        const MedialMesh& medial, const Primitive& primitive, const Vec3& p)
    {
        const auto& s = primitive.spheres;
        switch (primitive.kind) {
        case PrimitiveKind::cone: {
            const ConeDistance d = MedialCone(medial.centers.row(s[0]).transpose(),
                medial.radii(s[0]), medial.centers.row(s[1]).transpose(), medial.radii(s[1]))
                                       .distance(p);
            return { d.sphere_distance, Vec3(1.0 - d.t, d.t, 0.0) };
        }
        case PrimitiveKind::slab: {
            const SlabDistance d
                = MedialSlab(MedialSphere(medial.centers.row(s[0]).transpose(), medial.radii(s[0])),
                    MedialSphere(medial.centers.row(s[1]).transpose(), medial.radii(s[1])),
                    MedialSphere(medial.centers.row(s[2]).transpose(), medial.radii(s[2])))
                      .distance(p);
            return { d.sphere_distance, Vec3(d.ab(0), d.ab(1), 1.0 - d.ab(0) - d.ab(1)) };
        }
        case PrimitiveKind::sphere:
        default:
            return { (p - medial.centers.row(s[0]).transpose()).norm() - medial.radii(s[0]),
                Vec3(1.0, 0.0, 0.0) };
        }
    }

    // 1. Each vertex goes to the primitive whose sphere contains it most deeply; writes its
    // primitive and sphere weights to `data`.
    void assign_vertices(const MedialMesh& medial, const SurfaceMesh& surface,
        const std::vector<Primitive>& primitives, MedialCollisionData& data)
    {
        const Index num_vertices = surface.num_vertices();
        const Index num_primitives = static_cast<Index>(primitives.size());
        data.vertex_primitive.resize(num_vertices);
        data.vertex_parameter.resize(num_vertices, 3);
        tbb::parallel_for(Index(0), num_vertices, [&](Index v) {
            const Vec3 x = surface.positions.row(v).transpose();
            double best = std::numeric_limits<double>::infinity();
            Index best_primitive = -1;
            Vec3 best_t = Vec3::Zero();
            for (Index p = 0; p < num_primitives; ++p) {
                const Primitive& primitive = primitives[static_cast<size_t>(p)];
                // A primitive whose box is farther than the best depth cannot beat it.
                const double gap = primitive.box.exteriorDistance(x);
                if (gap > 0 && gap >= best)
                    continue;
                const auto [distance, t] = sphere_distance(medial, primitive, x);
                if (distance < best) {
                    best = distance;
                    best_primitive = p;
                    best_t = t;
                }
            }
            data.vertex_primitive(v) = static_cast<int>(best_primitive);
            data.vertex_parameter.row(v) = best_t.transpose();
        });
    }

    // 2. Faces under the primitives of their vertices (CSR over primitives).
    void list_faces_by_primitive(
        const SurfaceMesh& surface, Index num_primitives, MedialCollisionData& data)
    {
        std::vector<std::vector<int>> faces_of(static_cast<size_t>(num_primitives));
        for (Index f = 0; f < surface.num_faces(); ++f) {
            int owners[3];
            for (int k = 0; k < 3; ++k)
                owners[k] = data.vertex_primitive(surface.faces(f, k));
            for (int k = 0; k < 3; ++k)
                if ((k == 0 || owners[k] != owners[0]) && (k < 2 || owners[k] != owners[1]))
                    faces_of[static_cast<size_t>(owners[k])].push_back(static_cast<int>(f));
        }
        data.face_primitives_indptr.resize(num_primitives + 1);
        data.face_primitives_indptr(0) = 0;
        for (Index p = 0; p < num_primitives; ++p)
            data.face_primitives_indptr(p + 1) = data.face_primitives_indptr(p)
                + static_cast<int>(faces_of[static_cast<size_t>(p)].size());
        data.face_primitives.resize(data.face_primitives_indptr(num_primitives));
        for (Index p = 0; p < num_primitives; ++p)
            std::copy(faces_of[static_cast<size_t>(p)].begin(),
                faces_of[static_cast<size_t>(p)].end(),
                data.face_primitives.data() + data.face_primitives_indptr(p));
    }

    /// What the bound factors of every primitive read.
    struct BoundInputs {
        const SparseRowMatrix& surface_basis;
        const SparseRowMatrix& medial_basis;
        const std::vector<int>& column_handle; ///< per basis column, its handle
        const MedialCollisionData& data; ///< with the vertices' primitives and parameters
    };

    // One primitive's bound factors, (handle, factor) by increasing handle: per handle, the max
    // over the primitive's `vertices` of |beta_j(x)|, and 0 for every handle with weight at the
    // primitive's own spheres.
    std::vector<std::pair<int, double>> primitive_bound_factors(
        const Primitive& primitive, const std::vector<int>& vertices, const BoundInputs& in)
    {
        std::vector<std::pair<int, double>> beta; // (column, value), merged per vertex
        std::vector<std::pair<int, double>> handle_norm2; // (handle, |beta_j|^2) per vertex
        std::vector<std::pair<int, double>> result;
        auto add_row = [&](const SparseRowMatrix& m, Index row, double scale) {
            for (SparseRowMatrix::InnerIterator it(m, row); it; ++it)
                beta.emplace_back(static_cast<int>(it.col()), scale * it.value());
        };
        auto merge_max = [&](int handle, double value) {
            auto it = std::lower_bound(result.begin(), result.end(), std::make_pair(handle, -1.0),
                [](const auto& a, const auto& b) { return a.first < b.first; });
            if (it != result.end() && it->first == handle)
                it->second = std::max(it->second, value);
            else
                result.insert(it, { handle, value });
        };
        // Every handle with weight at the primitive's own spheres counts, even with no vertex.
        for (int s : primitive.spheres)
            if (s >= 0)
                for (SparseRowMatrix::InnerIterator it(in.medial_basis, s); it; ++it)
                    merge_max(in.column_handle[static_cast<size_t>(it.col())], 0.0);
        for (int v : vertices) {
            beta.clear();
            add_row(in.surface_basis, v, 1.0);
            for (int k = 0; k < 3; ++k)
                if (primitive.spheres[static_cast<size_t>(k)] >= 0
                    && in.data.vertex_parameter(v, k) != 0.0)
                    add_row(in.medial_basis, primitive.spheres[static_cast<size_t>(k)],
                        -in.data.vertex_parameter(v, k));
            std::sort(beta.begin(), beta.end(),
                [](const auto& a, const auto& b) { return a.first < b.first; });
            handle_norm2.clear();
            for (size_t i = 0; i < beta.size();) {
                const int column = beta[i].first;
                double value = 0.0;
                for (; i < beta.size() && beta[i].first == column; ++i)
                    value += beta[i].second;
                const int handle = in.column_handle[static_cast<size_t>(column)];
                if (handle_norm2.empty() || handle_norm2.back().first != handle)
                    handle_norm2.emplace_back(handle, 0.0);
                handle_norm2.back().second += value * value;
            }
            for (const auto& [handle, norm2] : handle_norm2)
                merge_max(handle, std::sqrt(norm2));
        }
        return result;
    }

    // Stores the primitives' bound factors in `data` (CSR over primitives).
    void store_bound_factors(
        const std::vector<std::vector<std::pair<int, double>>>& factors, MedialCollisionData& data)
    {
        const Index num_primitives = static_cast<Index>(factors.size());
        data.bound_indptr.resize(num_primitives + 1);
        data.bound_indptr(0) = 0;
        for (Index p = 0; p < num_primitives; ++p)
            data.bound_indptr(p + 1)
                = data.bound_indptr(p) + static_cast<int>(factors[static_cast<size_t>(p)].size());
        data.bound_handles.resize(data.bound_indptr(num_primitives));
        data.bound_factors.resize(data.bound_indptr(num_primitives));
        for (Index p = 0; p < num_primitives; ++p) {
            Index at = data.bound_indptr(p);
            for (const auto& [handle, factor] : factors[static_cast<size_t>(p)]) {
                data.bound_handles(at) = handle;
                data.bound_factors(at) = factor;
                ++at;
            }
        }
    }

    // 3. Bound factors: per primitive, per handle, max over enclosed vertices of |beta_j(x)|.
    void compute_bound_factors(const std::vector<Primitive>& primitives,
        const SparseRowMatrix& surface_basis, const SparseRowMatrix& medial_basis,
        const Eigen::Ref<const VecXi>& handle_column_offsets, MedialCollisionData& data)
    {
        const Index num_vertices = data.vertex_primitive.size();
        const Index num_handles = handle_column_offsets.size() - 1;
        const Index num_columns = surface_basis.cols();
        const Index num_primitives = static_cast<Index>(primitives.size());
        std::vector<int> column_handle(static_cast<size_t>(num_columns));
        for (Index j = 0; j < num_handles; ++j)
            for (Index c = handle_column_offsets(j); c < handle_column_offsets(j + 1); ++c)
                column_handle[static_cast<size_t>(c)] = static_cast<int>(j);
        std::vector<std::vector<int>> vertices_of(static_cast<size_t>(num_primitives));
        for (Index v = 0; v < num_vertices; ++v)
            vertices_of[static_cast<size_t>(data.vertex_primitive(v))].push_back(
                static_cast<int>(v));

        const BoundInputs inputs { surface_basis, medial_basis, column_handle, data };
        std::vector<std::vector<std::pair<int, double>>> factors(
            static_cast<size_t>(num_primitives));
        tbb::parallel_for(Index(0), num_primitives, [&](Index p) {
            factors[static_cast<size_t>(p)] = primitive_bound_factors(
                primitives[static_cast<size_t>(p)], vertices_of[static_cast<size_t>(p)], inputs);
        });
        store_bound_factors(factors, data);
    }

} // namespace

SparseRowMatrix interpolate_rows(const SparseRowMatrix& basis, const Eigen::Ref<const MatX4i>& tets,
    const Eigen::Ref<const VecXi>& tet, const Eigen::Ref<const MatX>& barycentric)
{
    std::vector<Eigen::Triplet<double>> entries;
    for (Index p = 0; p < tet.size(); ++p)
        for (int k = 0; k < 4; ++k) {
            const double w = barycentric(p, k);
            if (w == 0.0)
                continue;
            for (SparseRowMatrix::InnerIterator it(basis, tets(tet(p), k)); it; ++it)
                entries.emplace_back(
                    static_cast<int>(p), static_cast<int>(it.col()), w * it.value());
        }
    SparseRowMatrix rows(tet.size(), basis.cols());
    rows.setFromTriplets(entries.begin(), entries.end());
    return rows;
}

MedialCollisionData build_collision_data(const MedialMesh& medial, const SurfaceMesh& surface,
    const SparseRowMatrix& surface_basis, const SparseRowMatrix& medial_basis,
    const Eigen::Ref<const VecXi>& handle_column_offsets)
{
    const Index num_vertices = surface.num_vertices();
    const Index num_handles = handle_column_offsets.size() - 1;
    const Index num_columns = surface_basis.cols();
    MAT_CHECK(surface_basis.rows() == num_vertices && medial_basis.rows() == medial.num_spheres()
            && medial_basis.cols() == num_columns
            && handle_column_offsets(num_handles) == num_columns,
        "collision data: inconsistent basis sizes");
    const std::vector<Primitive> primitives = list_primitives(medial);
    const Index num_primitives = static_cast<Index>(primitives.size());
    if (num_primitives == 0)
        throw_error("the medial mesh has no sphere: nothing can enclose the surface");

    MedialCollisionData data;
    data.primitive_kind.resize(num_primitives);
    data.primitive_spheres.resize(num_primitives, 3);
    for (Index p = 0; p < num_primitives; ++p) {
        data.primitive_kind(p) = static_cast<int>(primitives[static_cast<size_t>(p)].kind);
        for (int k = 0; k < 3; ++k)
            data.primitive_spheres(p, k)
                = primitives[static_cast<size_t>(p)].spheres[static_cast<size_t>(k)];
    }
    assign_vertices(medial, surface, primitives, data);
    list_faces_by_primitive(surface, num_primitives, data);
    compute_bound_factors(primitives, surface_basis, medial_basis, handle_column_offsets, data);
    return data;
}

} // namespace mat
