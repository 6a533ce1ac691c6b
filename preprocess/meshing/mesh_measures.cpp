#include "preprocess/meshing/mesh_measures.hpp"

namespace mat {

double surface_signed_volume(const SurfaceMesh& surface)
{
    double six_volume = 0.0;
    for (Index f = 0; f < surface.num_faces(); ++f) {
        const Vec3 p0 = surface.positions.row(surface.faces(f, 0)).transpose();
        const Vec3 p1 = surface.positions.row(surface.faces(f, 1)).transpose();
        const Vec3 p2 = surface.positions.row(surface.faces(f, 2)).transpose();
        six_volume += p0.dot(p1.cross(p2));
    }
    return six_volume / 6.0;
}

VecX tet_signed_volumes(const TetMesh& mesh)
{
    VecX volumes(mesh.num_tets());
    for (Index t = 0; t < mesh.num_tets(); ++t) {
        const Vec3 p0 = mesh.positions.row(mesh.tets(t, 0)).transpose();
        Mat3 edges;
        for (int k = 1; k < 4; ++k)
            edges.col(k - 1) = mesh.positions.row(mesh.tets(t, k)).transpose() - p0;
        volumes(t) = edges.determinant() / 6.0;
    }
    return volumes;
}

} // namespace mat
