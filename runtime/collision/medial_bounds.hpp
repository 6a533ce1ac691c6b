#pragma once
// The deformed medial primitives of a body, enlarged so that each still encloses the surface
// vertices assigned to it (docs/method.md, section 4, step 1). Built once from the bake; each
// update moves the sphere centers with the reduced coordinates q and enlarges the radii of every
// primitive P by one increment delta_P, written per primitive into flat arrays for the broad
// phase (no allocation per update, parallel over primitives with TBB, the same result for any
// thread count).
//
// The bound (derivation in preprocess/collision/bound_data.hpp). With x' = x + B_x q, a surface
// point x assigned to P at sphere weights t satisfies, for ANY rigid motion (R, T),
//   x' - c'(t) = R (x - c(t)) + sum_j (Q_j - Q_j^rigid(R, T)) beta_j(x),
// because the basis reproduces affine fields exactly. Q_j is handle j's 3 x (4|10) block of q
// (rows [off_j, off_j+1) of q, transposed) and Q_j^rigid its value for the displacement
// (R - I) x + T: constant column (R - I) c_j + T, linear columns s_j (R - I), quadratic 0. Hence
//   |x' - c'(t)| <= r(t) + delta_P,  delta_P = sum_j factor_j sigma_max(Q_j - Q_j^rigid),
// whatever (R, T) is: the choice below only makes the bound tighter, never wrong.
//   R: sphere: polar factor of its handle's transform F_j = I + L_j / s_j (L_j the linear
//      columns); cone: polar factors at both ends, slerp at t = 1/2; slab: polar factor of the
//      mean of its three handles' transforms (on the creature sample the mean increment is 40%
//      smaller than with shape matching of the three deformed centers, which ignores the handles'
//      own rotation).
//   T: minimizes an upper bound of delta_P over T: from the factor-weighted mean of the
//      a_j = q_j,const - (R - I) c_j, 4 Weiszfeld (majorize-minimize) iterations on
//      sum_j factor_j sqrt(|a_j - T|^2 + |N_j|_F^2), N_j the other columns of Q_j - Q_j^rigid.
//      About 6% tighter on the creature than the paper's choice (T moving the primitive's
//      center); for a rigid motion of the whole body every a_j is the same T, which is then
//      returned exactly, so such a motion gives a zero increment.
// sigma_max^2 is the largest eigenvalue of the 3 x 3 Gram matrix (Q_j - Q_j^rigid)(...)^T, taken
// as a certified upper bound (medial_bounds_kernels.hpp), so that the increments stay upper
// bounds in floating point. Like the bake's factors (maxima over the assigned vertices), the
// bound covers the surface vertices.

#include <vector>

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"
#include "common/medial_primitives.hpp"
#include "common/mesh_types.hpp"

namespace mat {

/// How update() enlarges the radii.
enum class RadiusUpdate {
    bound, ///< the conservative bound, primitive rigid motion removed (the default)
    bound_without_rigid_removal, ///< the same bound with R = I, T = 0 (for comparison)
    lazy, ///< centers moved, radii unchanged: misses points under large deformation
};

class MedialBounds {
public:
    using CenterArray = Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>;
    using BoxArray = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;

    /// Validates and keeps copies of what the updates need (throws mat::Error naming the bad
    /// element). Handle j must sit at sphere j (one handle per sphere, as mat-bake makes them).
    ///   medial                 the inflated medial mesh of the bake, #S spheres
    ///   collision              the bake's collision data (#P primitives, #Vs surface vertices)
    ///   medial_basis           #S x k, rows of B at the sphere centers
    ///   handle_centers         m x 3 (m = #S)
    ///   handle_scales          m
    ///   handle_column_offsets  m + 1, handle j owns rows [off_j, off_j+1) of q
    MedialBounds(const MedialMesh& medial, const MedialCollisionData& collision,
        const SparseRowMatrix& medial_basis, const Eigen::Ref<const MatX3>& handle_centers,
        const Eigen::Ref<const VecX>& handle_scales,
        const Eigen::Ref<const VecXi>& handle_column_offsets);
    /// The same from the members of a bake.
    explicit MedialBounds(const BakeData& bake);

    /// Deformed, enlarged primitives for reduced coordinates `q`  k x 3 (x = X + B q). Throws
    /// mat::Error on a wrong size or a non-finite entry. The updates write the object's arrays:
    /// one object must not be updated from two threads at once.
    void update(const Eigen::Ref<const MatX3>& q, RadiusUpdate mode = RadiusUpdate::bound);

    /// For solvers without q: the sphere centers are given (`sphere_centers`  #S x 3, deformed)
    /// and delta_P = max(0, max over the surface vertices assigned to P of |x' - c'(t)| - r(t)),
    /// x' from `surface_positions`  #Vs x 3, t the vertex's sphere weights. Exact for the
    /// vertices only: each vertex lies in its enlarged sphere at t, and no smaller uniform
    /// increment achieves that. After cover_faces() the maximum also runs over the other
    /// corners of the triangles listed under P, so that every such triangle lies in the enlarged
    /// primitive (which is convex).
    /// `mode` lazy: the centers only, increments 0 (the other modes are the exact update).
    void update_from_positions(const Eigen::Ref<const MatX3>& surface_positions,
        const Eigen::Ref<const MatX3>& sphere_centers, RadiusUpdate mode = RadiusUpdate::bound);

    /// Adds to each primitive's vertices the other corners of the triangles listed under it
    /// (MedialCollisionData::face_primitives), each with the sphere weights of its nearest point
    /// on the primitive's center simplex at rest; update_from_positions() then encloses every
    /// listed triangle, not only its own vertices, so no intersection between triangles lies
    /// outside the primitives that list them (docs/method.md, section 4). The handle bound of
    /// update() still covers the assigned vertices only (a comparison variant). Calling it again
    /// changes nothing.
    ///   faces         #F x 3 surface triangles
    ///   rest_surface  #Vs x 3 the surface at rest (the medial mesh's coordinates)
    void cover_faces(const MedialCollisionData& collision, const Eigen::Ref<const MatX3i>& faces,
        const Eigen::Ref<const MatX3>& rest_surface);

    Index num_primitives() const { return m_counts.size(); }
    Index num_spheres() const { return m_rest_centers.rows(); }
    /// k, the rows of q.
    Index num_columns() const { return m_num_columns; }

    // ---- the result of the last update (the rest shape before any) ----
    /// #P spheres per primitive: 1 sphere, 2 cone, 3 slab (MedialCollisionData::primitive_kind).
    const VecXi& counts() const { return m_counts; }
    /// #P x 9: the deformed centers of the primitive's spheres, x y z each (unused: 0).
    const CenterArray& centers() const { return m_centers; }
    /// #P x 3: the enlarged radii of the primitive's spheres (unused: 0).
    const MatX3& radii() const { return m_radii; }
    /// #P x 6: axis-aligned box of the enlarged primitive, min x y z then max x y z.
    const BoxArray& boxes() const { return m_boxes; }
    /// #P: the radius increment delta_P of each primitive.
    const VecX& increments() const { return m_increments; }
    /// #S x 3: the deformed sphere centers.
    const MatX3& sphere_centers() const { return m_sphere_centers; }

    /// Sphere i (< counts()(p)) of primitive p, enlarged.
    MedialSphere sphere(Index p, int i) const;
    /// The axis-aligned box of primitive p.
    Box3 box(Index p) const;

private:
    // One (primitive, handle) term of the bound, with the handle's data copied in.
    struct BoundEntry {
        Vec3 center; ///< c_j
        double scale = 1.0; ///< s_j
        double factor = 0.0; ///< max over the primitive's points of |beta_j|
        int offset = 0; ///< first row of handle j in q
        int terms = 0; ///< 4 or 10
    };

    /// The rest spheres, each sphere's handle (checked) and the medial basis; m_length.
    void copy_spheres(const MedialMesh& medial, const SparseRowMatrix& medial_basis,
        const Eigen::Ref<const MatX3>& handle_centers, const Eigen::Ref<const VecX>& handle_scales,
        const Eigen::Ref<const VecXi>& handle_column_offsets);
    /// The primitives' sphere counts and indices (checked against the spheres).
    void copy_primitives(const MedialCollisionData& collision);
    /// The bound entries (checked), each with its handle's data copied in.
    void copy_bound_entries(const MedialCollisionData& collision,
        const Eigen::Ref<const MatX3>& handle_centers, const Eigen::Ref<const VecX>& handle_scales,
        const Eigen::Ref<const VecXi>& handle_column_offsets);
    /// The surface vertices per primitive (CSR, checked), with their sphere weights.
    void file_surface_vertices(const MedialCollisionData& collision);
    /// Sizes the scratch and the output, and writes the rest primitives.
    void reset_outputs();
    void deform_spheres(const Eigen::Ref<const MatX3>& q, bool rotations);
    Mat3 primitive_rotation(Index p) const;
    double bound_increment(Index p, const Eigen::Ref<const MatX3>& q, bool remove_rigid);
    void write_primitive(Index p, double increment);
    /// The sphere weights of the point of primitive p's center simplex (at rest) nearest to x.
    Vec3 nearest_parameter(Index p, const Vec3& x) const;

    // ---- immutable after construction ----
    Index m_num_columns = 0;
    MatX3 m_rest_centers; ///< #S x 3
    VecX m_rest_radii; ///< #S
    SparseRowMatrix m_medial_basis; ///< #S x k
    VecXi m_sphere_handle_offset; ///< #S, rows of q of the handle at each sphere
    VecX m_sphere_handle_scale; ///< #S
    MatX3i m_primitive_spheres; ///< #P x 3
    VecXi m_entry_begin; ///< #P + 1
    std::vector<BoundEntry> m_entries;
    /// #P + 1, CSR of the surface vertices assigned to each primitive (after cover_faces(),
    /// with the other corners of its triangles)
    VecXi m_vertex_begin;
    VecXi m_vertices; ///< vertex indices
    MatX3 m_vertex_parameter; ///< sphere weights, in the order of m_vertices
    Index m_num_surface_vertices = 0; ///< #Vs
    double m_length = 1.0; ///< size of the rest medial mesh (box diagonal + 2 max radius)

    // ---- scratch, sized at construction ----
    std::vector<Mat3> m_handle_rotations; ///< #S polar factors of the handle transforms
    std::vector<Mat3> m_handle_transforms; ///< #S, F_j = I + L_j / s_j
    std::vector<Vec3> m_entry_offsets; ///< per entry, a_j
    std::vector<Mat3> m_entry_grams; ///< per entry, N_j N_j^T

    // ---- output ----
    VecXi m_counts;
    CenterArray m_centers;
    MatX3 m_radii;
    BoxArray m_boxes;
    VecX m_increments;
    MatX3 m_sphere_centers;
};

} // namespace mat
