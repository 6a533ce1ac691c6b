#pragma once
// The bake file: ONE HDF5 file with everything the runtime needs (common/bake_data.hpp).
//
// Layout (format "medial-elastics-bake", version bake_format_version):
//   /               attributes format_name, format_version, length_unit, created_by
//   /provenance     surface_file, medial_file, surface_hash, medial_hash, options (JSON text)
//   /mesh           rest_positions n x 3, tets T x 4, dm_inverse T x 9, rest_volumes T,
//                   lumped_mass n
//   /surface        positions #Vs x 3, faces #F x 3, tet #Vs, barycentric #Vs x 4
//   /medial         centers #S x 3, radii #S, input_radii #S, cones #C x 2, slabs #L x 3,
//                   tet #S, barycentric #S x 4
//   /handles        centers m x 3, scales m, quadratic m, column_offsets m + 1
//   /weights        n x m CSR
//   /basis/nodes    n x k CSR;   /basis/medial   #S x k CSR
//   /pd             laplacian n x n CSR, reduced_laplacian k x k, reduced_mass k x k
//   /collision      primitive_kind, primitive_spheres, vertex_primitive, vertex_parameter,
//                   face_primitives_indptr, face_primitives, bound_indptr, bound_handles,
//                   bound_factors
// Sparse matrices are CSR groups (indptr, indices, data, shape), as scipy reads them.

#include <string>
#include <string_view>

#include "common/bake_data.hpp"

namespace mat {

inline constexpr const char* bake_format_name = "medial-elastics-bake";
inline constexpr int bake_format_version = 1;

/// Writes `bake` to `path` atomically: on any failure there is no file at `path`.
void write_bake(const std::string& path, const BakeData& bake);

/// Reads a bake and checks it: format and version, every shape against the others, every
/// index in range. Throws mat::Error naming the file and the dataset on any mismatch.
BakeData read_bake(const std::string& path);

/// FNV-1a 64-bit hash of a file's bytes, as "fnv1a64:<16 hex digits>". Throws if unreadable.
std::string hash_file(const std::string& path);

/// The same hash of bytes in memory (e.g. a generated medial mesh's .ma text).
std::string hash_text(std::string_view text);

} // namespace mat
