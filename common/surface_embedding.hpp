#pragma once
// The bake's surface carried by the tet mesh: each surface vertex is a fixed barycentric
// combination of the 4 nodes of its tet (the bake's embedding, docs/method.md section 2), so the
// rendered surface follows the simulated nodes exactly. The one definition of the embedding, for
// the baker (mat-bake --error) and the runtime (contacts, frames, checks). Flat arrays, parallel,
// no allocation per call.

#include "common/bake_data.hpp"
#include "common/eigen_types.hpp"

namespace mat {

class SurfaceEmbedding {
public:
    /// Throws mat::Error if the embedding's shapes disagree with the surface or the tet mesh.
    explicit SurfaceEmbedding(const BakeData& bake);

    Index num_vertices() const { return m_nodes.rows(); }
    const MatX3i& faces() const { return m_faces; } ///< F x 3
    const VecXi& tets() const { return m_tet; } ///< #Vs: the tet each vertex is embedded in
    /// The embedding: vertex v = sum_c weights(v, c) x_{nodes(v, c)}  (#Vs x 4 each).
    const MatX4i& nodes() const { return m_nodes; }
    const MatX& weights() const { return m_weights; }

    /// Surface vertex positions  #Vs x 3 from node positions `nodes`  n x 3.
    void positions(const Eigen::Ref<const MatX3>& nodes, Eigen::Ref<MatX3> out) const;
    /// The same interpolation for any per-node field  n x 3 (velocities).
    void interpolate(const Eigen::Ref<const MatX3>& field, Eigen::Ref<MatX3> out) const
    {
        positions(field, out);
    }

private:
    MatX4i m_nodes; ///< #Vs x 4
    MatX m_weights; ///< #Vs x 4
    MatX3i m_faces;
    VecXi m_tet;
};

} // namespace mat
