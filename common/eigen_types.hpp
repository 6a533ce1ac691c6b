#pragma once
// The one header of Eigen aliases. Vertex arrays are row-major #V x 3, so that a row binds to
// Ref<const Vector3d> without a copy and the storage is the interleaved x0,y0,z0,x1,... vector.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mat {

using Index = Eigen::Index;

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using VecX = Eigen::VectorXd;
using VecXi = Eigen::VectorXi;
using MatX = Eigen::MatrixXd;
using Box3 = Eigen::AlignedBox3d;

/// #V x 3 positions, row-major (interleaved x, y, z).
using MatX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #E x 2 index pairs (edges, cones).
using MatX2i = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;
/// #F x 3 index triples (triangles, slabs).
using MatX3i = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #T x 4 index quadruples (tetrahedra).
using MatX4i = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

} // namespace mat
