#include "runtime/body_model.hpp"

namespace mat {

BodyModel::BodyModel(const BakeData& bake, const Material& material, const ModelOptions& options)
    : m_pd(bake, material, options)
    , m_surface(bake)
    , m_rest_surface(bake.surface.positions)
    , m_medial(bake.medial)
    , m_primitives(bake.collision)
    , m_medial_basis(bake.medial_basis)
    , m_medial_tet(bake.medial_tet)
    , m_medial_barycentric(bake.medial_barycentric)
    , m_num_handles(bake.num_handles())
{
    const MatX3& rest = bake.tet_mesh.positions;
    m_rest_diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
}

} // namespace mat
