#pragma once
// A body's immutable data for a run, built once from its bake (docs/method.md, sections 2-4).

#include <memory>

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"
#include "common/mesh_types.hpp"
#include "common/surface_embedding.hpp"
#include "runtime/model.hpp"

namespace mat {

/// Everything a run reads about one body and never changes, built once from its bake: the PD
/// system (Model: material, masses, pins, the handle basis, the factored matrices), the surface
/// embedded in the tets, and the collision data (the medial mesh, its primitives and their
/// surface vertices, the spheres' embedding in the tets). The simulation, the collision world,
/// the exporter and the checks all read this one object; nothing else keeps a copy of the bake.
class BodyModel {
public:
    /// Throws mat::Error if the bake's shapes disagree (Model, SurfaceEmbedding) or the model
    /// cannot be built (a factorization fails).
    BodyModel(const BakeData& bake, const Material& material, const ModelOptions& options);

    /// With the default material and model options: for tools and tests that read only its
    /// geometry and collision data.
    static std::shared_ptr<const BodyModel> from_bake(const BakeData& bake)
    {
        return std::make_shared<const BodyModel>(bake, Material {}, ModelOptions {});
    }

    /// The projective dynamics system.
    const Model& pd() const { return m_pd; }
    /// The visible surface, carried by the tet nodes.
    const SurfaceEmbedding& surface() const { return m_surface; }
    /// The rest surface  #Vs x 3 (bake coordinates).
    const MatX3& rest_surface() const { return m_rest_surface; }

    // Collision data (docs/method.md, section 4).
    const MedialMesh& medial() const { return m_medial; }
    /// The medial primitives, each surface vertex's primitive, and their bounds' handle factors.
    const MedialCollisionData& primitives() const { return m_primitives; }
    /// Rows of the basis B at the sphere centers  #S x k.
    const SparseRowMatrix& medial_basis() const { return m_medial_basis; }
    /// The spheres' embedding in the tets: containing tet  #S, barycentric weights  #S x 4.
    const VecXi& medial_tet() const { return m_medial_tet; }
    const MatX& medial_barycentric() const { return m_medial_barycentric; }

    Index num_handles() const { return m_num_handles; }
    /// The rest bounding box's diagonal (m, bake coordinates).
    double rest_diagonal() const { return m_rest_diagonal; }

private:
    Model m_pd;
    SurfaceEmbedding m_surface;
    MatX3 m_rest_surface;
    MedialMesh m_medial;
    MedialCollisionData m_primitives;
    SparseRowMatrix m_medial_basis;
    VecXi m_medial_tet;
    MatX m_medial_barycentric;
    Index m_num_handles = 0;
    double m_rest_diagonal = 0.0;
};

} // namespace mat
