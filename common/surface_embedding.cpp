#include "common/surface_embedding.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"

namespace mat {

SurfaceEmbedding::SurfaceEmbedding(const BakeData& bake)
{
    const Index vs = bake.surface.positions.rows();
    const Index t = bake.tet_mesh.num_tets();
    if (bake.surface_tet.size() != vs || bake.surface_barycentric.rows() != vs
        || bake.surface_barycentric.cols() != 4)
        throw_error("bake: the surface embedding has {} tets and {} x {} barycentric "
                    "coordinates for {} surface vertices",
            bake.surface_tet.size(), bake.surface_barycentric.rows(),
            bake.surface_barycentric.cols(), vs);
    m_nodes.resize(vs, 4);
    m_weights = bake.surface_barycentric;
    for (Index v = 0; v < vs; ++v) {
        const int e = bake.surface_tet(v);
        if (e < 0 || e >= t)
            throw_error(
                "bake: surface vertex {} is embedded in tet {}, out of range [0, {})", v, e, t);
        m_nodes.row(v) = bake.tet_mesh.tets.row(e);
    }
    m_faces = bake.surface.faces;
    m_tet = bake.surface_tet;
}

void SurfaceEmbedding::positions(const Eigen::Ref<const MatX3>& nodes, Eigen::Ref<MatX3> out) const
{
    MAT_CHECK(out.rows() == m_nodes.rows(), "surface embedding: output has {} rows, expected {}",
        out.rows(), m_nodes.rows());
    tbb::parallel_for(
        tbb::blocked_range<Index>(0, m_nodes.rows()), [&](const tbb::blocked_range<Index>& range) {
            for (Index v = range.begin(); v != range.end(); ++v) {
                Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
                for (int c = 0; c < 4; ++c)
                    x += m_weights(v, c) * nodes.row(m_nodes(v, c));
                out.row(v) = x;
            }
        });
}

} // namespace mat
