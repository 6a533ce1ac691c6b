#include "formats/bake_io.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <vector>

#include "common/error.hpp"
#include "common/version.hpp"
#include "formats/hdf5_file.hpp"

namespace mat {

namespace {

    void write_ints(H5Writer& out, const std::string& path, const VecXi& v)
    {
        out.write_vector(path, v);
    }

} // namespace

void write_bake(const std::string& path, const BakeData& bake)
{
    H5Writer out(path);
    out.stamp_format(bake_format_name, bake_format_version);
    out.set_attribute("/", "length_unit", bake.length_unit);
    out.set_attribute("/", "created_by", std::string("mat-bake ") + version_string);

    out.write_string("provenance/surface_file", bake.surface_file);
    out.write_string("provenance/medial_file", bake.medial_file);
    out.write_string("provenance/surface_hash", bake.surface_hash);
    out.write_string("provenance/medial_hash", bake.medial_hash);
    out.write_string("provenance/options", bake.options_json);

    out.write_matrix("mesh/rest_positions", bake.tet_mesh.positions);
    out.write_matrix("mesh/tets", bake.tet_mesh.tets);
    out.write_matrix("mesh/dm_inverse", bake.dm_inverse);
    out.write_vector("mesh/rest_volumes", bake.rest_volumes);
    out.write_vector("mesh/lumped_mass", bake.lumped_mass);

    out.write_matrix("surface/positions", bake.surface.positions);
    out.write_matrix("surface/faces", bake.surface.faces);
    write_ints(out, "surface/tet", bake.surface_tet);
    out.write_matrix("surface/barycentric", bake.surface_barycentric);
    out.set_attribute(
        "surface", "outside_count", static_cast<std::int64_t>(bake.surface_outside_count));

    out.write_matrix("medial/centers", bake.medial.centers);
    out.write_vector("medial/radii", bake.medial.radii);
    out.write_vector("medial/input_radii", bake.medial_input_radii);
    out.write_matrix("medial/cones", bake.medial.cones);
    out.write_matrix("medial/slabs", bake.medial.slabs);
    write_ints(out, "medial/tet", bake.medial_tet);
    out.write_matrix("medial/barycentric", bake.medial_barycentric);
    out.set_attribute("medial", "inflation", bake.medial_inflation);

    out.write_matrix("handles/centers", bake.handle_centers);
    out.write_vector("handles/scales", bake.handle_scales);
    write_ints(out, "handles/quadratic", bake.handle_quadratic);
    write_ints(out, "handles/column_offsets", bake.handle_column_offsets);

    out.write_sparse("weights", bake.weights);
    out.write_sparse("basis/nodes", bake.basis);
    out.write_sparse("basis/medial", bake.medial_basis);

    out.write_sparse("pd/laplacian", bake.laplacian);
    out.write_matrix("pd/reduced_laplacian", bake.reduced_laplacian);
    out.write_matrix("pd/reduced_mass", bake.reduced_mass);

    const MedialCollisionData& c = bake.collision;
    write_ints(out, "collision/primitive_kind", c.primitive_kind);
    out.write_matrix("collision/primitive_spheres", c.primitive_spheres);
    write_ints(out, "collision/vertex_primitive", c.vertex_primitive);
    out.write_matrix("collision/vertex_parameter", c.vertex_parameter);
    write_ints(out, "collision/face_primitives_indptr", c.face_primitives_indptr);
    write_ints(out, "collision/face_primitives", c.face_primitives);
    write_ints(out, "collision/bound_indptr", c.bound_indptr);
    write_ints(out, "collision/bound_handles", c.bound_handles);
    out.write_vector("collision/bound_factors", c.bound_factors);

    out.commit();
}

namespace {

    // Every index of `indices` must lie in [0, limit) (or be -1 where allowed).
    template <typename Derived>
    void check_range(const std::string& file, const std::string& dataset,
        const Eigen::DenseBase<Derived>& indices, Index limit, bool allow_minus_one = false)
    {
        for (Index i = 0; i < indices.rows(); ++i)
            for (Index j = 0; j < indices.cols(); ++j) {
                const Index v = indices(i, j);
                if ((v < 0 || v >= limit) && !(allow_minus_one && v == -1))
                    throw_error("{}: {}: entry ({}, {}) = {} is outside [0, {})", file, dataset, i,
                        j, v, limit);
            }
    }

    void check_indptr(const std::string& file, const std::string& dataset, const VecXi& indptr,
        Index rows, Index entries)
    {
        if (indptr.size() != rows + 1)
            throw_error(
                "{}: {}: expected {} entries, found {}", file, dataset, rows + 1, indptr.size());
        if (indptr(0) != 0 || indptr(rows) != entries)
            throw_error("{}: {}: must run from 0 to {}", file, dataset, entries);
        for (Index i = 0; i < rows; ++i)
            if (indptr(i + 1) < indptr(i))
                throw_error("{}: {}: decreases at entry {}", file, dataset, i + 1);
    }

    template <typename Derived>
    void check_finite(
        const std::string& file, const std::string& dataset, const Eigen::DenseBase<Derived>& a)
    {
        for (Index i = 0; i < a.rows(); ++i)
            for (Index j = 0; j < a.cols(); ++j)
                if (!std::isfinite(a(i, j)))
                    throw_error(
                        "{}: {}: entry ({}, {}) = {} is not finite", file, dataset, i, j, a(i, j));
    }

    void check_finite(const std::string& file, const std::string& group, const SparseRowMatrix& a)
    {
        for (Index k = 0; k < a.nonZeros(); ++k)
            if (!std::isfinite(a.valuePtr()[k]))
                throw_error(
                    "{}: {}/data: entry {} = {} is not finite", file, group, k, a.valuePtr()[k]);
    }

    void check_positive(const std::string& file, const std::string& dataset, const VecX& values)
    {
        for (Index i = 0; i < values.size(); ++i)
            if (!(values(i) > 0.0) || !std::isfinite(values(i)))
                throw_error("{}: {}: entry {} = {}, expected a finite value > 0", file, dataset, i,
                    values(i));
    }

    // The numbers a bake can hold only if it is damaged: NaN or infinite values anywhere,
    // volumes, masses, radii or handle scales <= 0.
    void check_values(const std::string& f, const BakeData& b)
    {
        check_finite(f, "mesh/rest_positions", b.tet_mesh.positions);
        check_finite(f, "mesh/dm_inverse", b.dm_inverse);
        check_positive(f, "mesh/rest_volumes", b.rest_volumes);
        check_positive(f, "mesh/lumped_mass", b.lumped_mass);
        check_finite(f, "surface/positions", b.surface.positions);
        check_finite(f, "surface/barycentric", b.surface_barycentric);
        check_finite(f, "medial/centers", b.medial.centers);
        check_positive(f, "medial/radii", b.medial.radii);
        check_positive(f, "medial/input_radii", b.medial_input_radii);
        check_finite(f, "medial/barycentric", b.medial_barycentric);
        if (!std::isfinite(b.medial_inflation) || b.medial_inflation < 0.0)
            throw_error("{}: medial: attribute 'inflation' = {}, expected a finite value >= 0", f,
                b.medial_inflation);
        check_finite(f, "handles/centers", b.handle_centers);
        check_positive(f, "handles/scales", b.handle_scales);
        check_finite(f, "weights", b.weights);
        check_finite(f, "basis/nodes", b.basis);
        check_finite(f, "basis/medial", b.medial_basis);
        check_finite(f, "pd/laplacian", b.laplacian);
        check_finite(f, "pd/reduced_laplacian", b.reduced_laplacian);
        check_finite(f, "pd/reduced_mass", b.reduced_mass);
        check_finite(f, "collision/vertex_parameter", b.collision.vertex_parameter);
        check_finite(f, "collision/bound_factors", b.collision.bound_factors);
    }

} // namespace

BakeData read_bake(const std::string& path)
{
    H5Reader in(path);
    in.require_format(bake_format_name, bake_format_version, "this build of mat-bake and mat-run");
    const std::string& f = path;
    BakeData b;
    b.length_unit = in.read_string_attribute("/", "length_unit");
    b.surface_file = in.read_string("provenance/surface_file");
    b.medial_file = in.read_string("provenance/medial_file");
    b.surface_hash = in.read_string("provenance/surface_hash");
    b.medial_hash = in.read_string("provenance/medial_hash");
    b.options_json = in.read_string("provenance/options");

    b.tet_mesh.positions = in.read<MatX3>("mesh/rest_positions");
    const Index n = b.tet_mesh.positions.rows();
    b.tet_mesh.tets = in.read<MatX4i>("mesh/tets");
    const Index num_tets = b.tet_mesh.tets.rows();
    check_range(f, "mesh/tets", b.tet_mesh.tets, n);
    b.dm_inverse = in.read_matrix("mesh/dm_inverse", num_tets, 9);
    b.rest_volumes = in.read<VecX>("mesh/rest_volumes", num_tets);
    b.lumped_mass = in.read<VecX>("mesh/lumped_mass", n);

    b.surface.positions = in.read<MatX3>("surface/positions");
    const Index num_surface = b.surface.positions.rows();
    b.surface.faces = in.read<MatX3i>("surface/faces");
    check_range(f, "surface/faces", b.surface.faces, num_surface);
    b.surface_tet = in.read<VecXi>("surface/tet", num_surface);
    check_range(f, "surface/tet", b.surface_tet, num_tets);
    b.surface_barycentric = in.read_matrix("surface/barycentric", num_surface, 4);
    b.surface_outside_count = in.read_int_attribute("surface", "outside_count");

    b.medial.centers = in.read<MatX3>("medial/centers");
    const Index num_spheres = b.medial.centers.rows();
    b.medial.radii = in.read<VecX>("medial/radii", num_spheres);
    b.medial_input_radii = in.read<VecX>("medial/input_radii", num_spheres);
    b.medial.cones = in.read<MatX2i>("medial/cones");
    check_range(f, "medial/cones", b.medial.cones, num_spheres);
    b.medial.slabs = in.read<MatX3i>("medial/slabs");
    check_range(f, "medial/slabs", b.medial.slabs, num_spheres);
    b.medial_tet = in.read<VecXi>("medial/tet", num_spheres);
    check_range(f, "medial/tet", b.medial_tet, num_tets);
    b.medial_barycentric = in.read_matrix("medial/barycentric", num_spheres, 4);
    b.medial_inflation = in.read_double_attribute("medial", "inflation");

    b.handle_centers = in.read<MatX3>("handles/centers");
    const Index m = b.handle_centers.rows();
    b.handle_scales = in.read<VecX>("handles/scales", m);
    b.handle_quadratic = in.read<VecXi>("handles/quadratic", m);
    b.handle_column_offsets = in.read<VecXi>("handles/column_offsets", m + 1);
    b.weights = in.read_sparse("weights", n, m);
    b.basis = in.read_sparse("basis/nodes", n);
    const Index k = b.basis.cols();
    check_indptr(f, "handles/column_offsets", b.handle_column_offsets, m, k);
    b.medial_basis = in.read_sparse("basis/medial", num_spheres, k);

    b.laplacian = in.read_sparse("pd/laplacian", n, n);
    b.reduced_laplacian = in.read_matrix("pd/reduced_laplacian", k, k);
    b.reduced_mass = in.read_matrix("pd/reduced_mass", k, k);

    MedialCollisionData& c = b.collision;
    c.primitive_kind = in.read<VecXi>("collision/primitive_kind");
    const Index num_primitives = c.primitive_kind.size();
    check_range(f, "collision/primitive_kind", c.primitive_kind, 3);
    c.primitive_spheres = in.read<MatX3i>("collision/primitive_spheres", num_primitives);
    check_range(f, "collision/primitive_spheres", c.primitive_spheres, num_spheres, true);
    c.vertex_primitive = in.read<VecXi>("collision/vertex_primitive", num_surface);
    check_range(f, "collision/vertex_primitive", c.vertex_primitive, num_primitives);
    c.vertex_parameter = in.read<MatX3>("collision/vertex_parameter", num_surface);
    c.face_primitives_indptr
        = in.read<VecXi>("collision/face_primitives_indptr", num_primitives + 1);
    c.face_primitives = in.read<VecXi>("collision/face_primitives");
    check_indptr(f, "collision/face_primitives_indptr", c.face_primitives_indptr, num_primitives,
        c.face_primitives.size());
    check_range(f, "collision/face_primitives", c.face_primitives, b.surface.faces.rows());
    c.bound_indptr = in.read<VecXi>("collision/bound_indptr", num_primitives + 1);
    c.bound_handles = in.read<VecXi>("collision/bound_handles");
    c.bound_factors = in.read<VecX>("collision/bound_factors", c.bound_handles.size());
    check_indptr(
        f, "collision/bound_indptr", c.bound_indptr, num_primitives, c.bound_handles.size());
    check_range(f, "collision/bound_handles", c.bound_handles, m);
    check_values(f, b);
    return b;
}

std::string hash_file(const std::string& path)
{
    std::ifstream file(path, std::ios::binary);
    if (!file)
        throw_error("{}: cannot read the file to hash it", path);
    std::uint64_t hash = 1469598103934665603ull; // FNV-1a 64 offset basis
    std::vector<char> buffer(1 << 16);
    while (file) {
        file.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
        const std::streamsize got = file.gcount();
        for (std::streamsize i = 0; i < got; ++i) {
            hash ^= static_cast<unsigned char>(buffer[static_cast<size_t>(i)]);
            hash *= 1099511628211ull; // FNV-1a 64 prime
        }
    }
    return fmt::format("fnv1a64:{:016x}", hash);
}

std::string hash_text(std::string_view text)
{
    std::uint64_t hash = 1469598103934665603ull; // FNV-1a 64 offset basis
    for (const char c : text) {
        hash ^= static_cast<unsigned char>(c);
        hash *= 1099511628211ull; // FNV-1a 64 prime
    }
    return fmt::format("fnv1a64:{:016x}", hash);
}

} // namespace mat
