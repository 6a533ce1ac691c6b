#include "runtime/collision/medial_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "common/error.hpp"
#include "runtime/collision/medial_bounds_kernels.hpp"
#include "runtime/collision/triangle_tests.hpp"

namespace mat {

namespace {

    // Weiszfeld iterations for the translation: 4 get ~99% of what 100 get on the creature.
    constexpr int translation_iterations = 4;
    constexpr Index grain = 8;

    int sphere_count(int kind)
    {
        switch (static_cast<PrimitiveKind>(kind)) {
        case PrimitiveKind::sphere:
            return 1;
        case PrimitiveKind::cone:
            return 2;
        case PrimitiveKind::slab:
            return 3;
        }
        return 0;
    }

    /// Throws unless the medial mesh's spheres are finite, with one handle per sphere and one
    /// basis row per sphere, the handles' columns spanning the basis's.
    void check_spheres_and_handles(const MedialMesh& medial, const SparseRowMatrix& medial_basis,
        const Eigen::Ref<const MatX3>& handle_centers, const Eigen::Ref<const VecX>& handle_scales,
        const Eigen::Ref<const VecXi>& handle_column_offsets)
    {
        const Index num_spheres = medial.num_spheres();
        if (num_spheres == 0)
            throw_error("medial bounds: the medial mesh has no sphere");
        if (medial.radii.size() != num_spheres)
            throw_error("medial bounds: {} radii for {} spheres", medial.radii.size(), num_spheres);
        for (Index s = 0; s < num_spheres; ++s)
            if (!medial.centers.row(s).allFinite() || !(medial.radii(s) >= 0.0)
                || !std::isfinite(medial.radii(s)))
                throw_error("medial bounds: sphere {} has a non-finite center or a bad radius {}",
                    s, medial.radii(s));
        if (handle_centers.rows() != num_spheres || handle_scales.size() != num_spheres
            || handle_column_offsets.size() != num_spheres + 1)
            throw_error("medial bounds: {} handle centers, {} scales and {} column offsets for {} "
                        "spheres (expected one handle per sphere)",
                handle_centers.rows(), handle_scales.size(), handle_column_offsets.size(),
                num_spheres);
        if (medial_basis.rows() != num_spheres)
            throw_error("medial bounds: the medial basis has {} rows for {} spheres",
                medial_basis.rows(), num_spheres);
        const Index num_columns = medial_basis.cols();
        if (handle_column_offsets(0) != 0 || handle_column_offsets(num_spheres) != num_columns)
            throw_error("medial bounds: handle columns span [{}, {}), expected [0, {})",
                handle_column_offsets(0), handle_column_offsets(num_spheres), num_columns);
    }

} // namespace

MedialBounds::MedialBounds(const MedialMesh& medial, const MedialCollisionData& collision,
    const SparseRowMatrix& medial_basis, const Eigen::Ref<const MatX3>& handle_centers,
    const Eigen::Ref<const VecX>& handle_scales,
    const Eigen::Ref<const VecXi>& handle_column_offsets)
{
    check_spheres_and_handles(
        medial, medial_basis, handle_centers, handle_scales, handle_column_offsets);
    m_num_columns = medial_basis.cols();
    copy_spheres(medial, medial_basis, handle_centers, handle_scales, handle_column_offsets);
    copy_primitives(collision);
    copy_bound_entries(collision, handle_centers, handle_scales, handle_column_offsets);
    file_surface_vertices(collision);
    reset_outputs();
}

void MedialBounds::copy_spheres(const MedialMesh& medial, const SparseRowMatrix& medial_basis,
    const Eigen::Ref<const MatX3>& handle_centers, const Eigen::Ref<const VecX>& handle_scales,
    const Eigen::Ref<const VecXi>& handle_column_offsets)
{
    const Index num_spheres = medial.num_spheres();
    m_rest_centers = medial.centers;
    m_rest_radii = medial.radii;
    const Box3 rest_box(medial.centers.colwise().minCoeff().transpose(),
        medial.centers.colwise().maxCoeff().transpose());
    m_length = std::max(rest_box.diagonal().norm() + 2.0 * medial.radii.maxCoeff(), 1e-300);
    m_sphere_handle_offset.resize(num_spheres);
    m_sphere_handle_scale.resize(num_spheres);
    for (Index j = 0; j < num_spheres; ++j) {
        const int terms = handle_column_offsets(j + 1) - handle_column_offsets(j);
        if (terms != 4 && terms != 10)
            throw_error(
                "medial bounds: handle {} owns {} basis columns (expected 4 or 10)", j, terms);
        if (!(handle_scales(j) > 0.0) || !std::isfinite(handle_scales(j)))
            throw_error("medial bounds: handle {} has scale {} (must be finite and > 0)", j,
                handle_scales(j));
        if (!((handle_centers.row(j) - medial.centers.row(j)).norm() <= 1e-9 * m_length))
            throw_error("medial bounds: handle {} is not at sphere {} (expected one handle per "
                        "sphere, in sphere order)",
                j, j);
        m_sphere_handle_offset(j) = handle_column_offsets(j);
        m_sphere_handle_scale(j) = handle_scales(j);
    }
    m_medial_basis = medial_basis;
    m_medial_basis.makeCompressed();
}

void MedialBounds::copy_primitives(const MedialCollisionData& collision)
{
    const Index num_spheres = this->num_spheres();
    const Index num_primitives = collision.primitive_kind.size();
    if (collision.primitive_spheres.rows() != num_primitives
        || collision.bound_indptr.size() != num_primitives + 1
        || collision.bound_handles.size() != collision.bound_factors.size())
        throw_error("medial bounds: collision data sizes disagree ({} kinds, {} sphere rows, {} "
                    "bound offsets, {} handles, {} factors)",
            num_primitives, collision.primitive_spheres.rows(), collision.bound_indptr.size(),
            collision.bound_handles.size(), collision.bound_factors.size());
    m_counts.resize(num_primitives);
    m_primitive_spheres = collision.primitive_spheres;
    for (Index p = 0; p < num_primitives; ++p) {
        const int count = sphere_count(collision.primitive_kind(p));
        if (count == 0)
            throw_error("medial bounds: primitive {} has kind {} (expected 0 sphere, 1 cone, "
                        "2 slab)",
                p, collision.primitive_kind(p));
        for (int i = 0; i < 3; ++i) {
            const int s = collision.primitive_spheres(p, i);
            if (i < count ? (s < 0 || s >= num_spheres) : s != -1)
                throw_error("medial bounds: primitive {} has sphere index {} in slot {} (the "
                            "medial mesh has {} spheres)",
                    p, s, i, num_spheres);
        }
        m_counts(p) = count;
    }
}

void MedialBounds::copy_bound_entries(const MedialCollisionData& collision,
    const Eigen::Ref<const MatX3>& handle_centers, const Eigen::Ref<const VecX>& handle_scales,
    const Eigen::Ref<const VecXi>& handle_column_offsets)
{
    const Index num_spheres = this->num_spheres();
    const Index num_primitives = this->num_primitives();
    m_entry_begin = collision.bound_indptr;
    if (m_entry_begin(0) != 0 || m_entry_begin(num_primitives) != collision.bound_handles.size())
        throw_error("medial bounds: the bound offsets span [{}, {}) for {} entries",
            m_entry_begin(0), m_entry_begin(num_primitives), collision.bound_handles.size());
    for (Index p = 0; p < num_primitives; ++p)
        if (m_entry_begin(p + 1) < m_entry_begin(p))
            throw_error("medial bounds: the bound offsets decrease at primitive {}", p);
    m_entries.resize(static_cast<size_t>(collision.bound_handles.size()));
    for (Index p = 0; p < num_primitives; ++p) {
        for (int e = m_entry_begin(p); e < m_entry_begin(p + 1); ++e) {
            const int j = collision.bound_handles(e);
            const double factor = collision.bound_factors(e);
            if (j < 0 || j >= num_spheres)
                throw_error("medial bounds: bound entry {} of primitive {} names handle {} (there "
                            "are {} handles)",
                    e, p, j, num_spheres);
            if (!(factor >= 0.0) || !std::isfinite(factor))
                throw_error(
                    "medial bounds: bound entry {} of primitive {} has factor {}", e, p, factor);
            BoundEntry& entry = m_entries[static_cast<size_t>(e)];
            entry.center = handle_centers.row(j).transpose();
            entry.scale = handle_scales(j);
            entry.factor = factor;
            entry.offset = handle_column_offsets(j);
            entry.terms = handle_column_offsets(j + 1) - handle_column_offsets(j);
        }
    }
}

void MedialBounds::file_surface_vertices(const MedialCollisionData& collision)
{
    const Index num_primitives = this->num_primitives();
    const Index num_vertices = collision.vertex_primitive.size();
    if (collision.vertex_parameter.rows() != num_vertices)
        throw_error("medial bounds: {} vertex parameters for {} vertices",
            collision.vertex_parameter.rows(), num_vertices);
    m_vertex_begin = VecXi::Zero(num_primitives + 1);
    for (Index v = 0; v < num_vertices; ++v) {
        const int p = collision.vertex_primitive(v);
        if (p < 0 || p >= num_primitives)
            throw_error("medial bounds: surface vertex {} is assigned to primitive {} (there are "
                        "{} primitives)",
                v, p, num_primitives);
        if (!collision.vertex_parameter.row(v).allFinite())
            throw_error("medial bounds: surface vertex {} has a non-finite parameter", v);
        ++m_vertex_begin(p + 1);
    }
    for (Index p = 0; p < num_primitives; ++p)
        m_vertex_begin(p + 1) += m_vertex_begin(p);
    m_num_surface_vertices = num_vertices;
    m_vertices.resize(num_vertices);
    m_vertex_parameter.resize(num_vertices, 3);
    VecXi fill = m_vertex_begin.head(num_primitives);
    for (Index v = 0; v < num_vertices; ++v) {
        const int at = fill(collision.vertex_primitive(v))++;
        m_vertices(at) = static_cast<int>(v);
        m_vertex_parameter.row(at) = collision.vertex_parameter.row(v);
    }
}

void MedialBounds::cover_faces(const MedialCollisionData& collision,
    const Eigen::Ref<const MatX3i>& faces, const Eigen::Ref<const MatX3>& rest_surface)
{
    const Index num_primitives = this->num_primitives();
    if (rest_surface.rows() != m_num_surface_vertices
        || collision.face_primitives_indptr.size() != num_primitives + 1)
        throw_error("medial bounds: cover_faces with {} vertices and {} face lists, expected {} "
                    "and {}",
            rest_surface.rows(), collision.face_primitives_indptr.size() - 1,
            m_num_surface_vertices, num_primitives);
    std::vector<int> begin { 0 };
    std::vector<int> vertices;
    std::vector<Vec3> parameters;
    std::vector<int> corners;
    for (Index p = 0; p < num_primitives; ++p) {
        // The vertices assigned to p (a second call adds the same corners again, not twice).
        for (int at = m_vertex_begin(p); at < m_vertex_begin(p + 1); ++at)
            if (collision.vertex_primitive(m_vertices(at)) == p) {
                vertices.push_back(m_vertices(at));
                parameters.push_back(m_vertex_parameter.row(at).transpose());
            }
        corners.clear();
        for (int i = collision.face_primitives_indptr(p);
             i < collision.face_primitives_indptr(p + 1); ++i) {
            const int f = collision.face_primitives(i);
            if (f < 0 || f >= faces.rows())
                throw_error("medial bounds: primitive {} lists face {} of {}", p, f, faces.rows());
            for (int k = 0; k < 3; ++k)
                if (collision.vertex_primitive(faces(f, k)) != p)
                    corners.push_back(faces(f, k));
        }
        std::sort(corners.begin(), corners.end());
        corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
        for (const int v : corners) {
            vertices.push_back(v);
            parameters.push_back(nearest_parameter(p, rest_surface.row(v).transpose()));
        }
        begin.push_back(static_cast<int>(vertices.size()));
    }
    m_vertex_begin = Eigen::Map<const VecXi>(begin.data(), static_cast<Index>(begin.size()));
    m_vertices = Eigen::Map<const VecXi>(vertices.data(), static_cast<Index>(vertices.size()));
    m_vertex_parameter.resize(static_cast<Index>(parameters.size()), 3);
    for (std::size_t i = 0; i < parameters.size(); ++i)
        m_vertex_parameter.row(static_cast<Index>(i)) = parameters[i].transpose();
}

Vec3 MedialBounds::nearest_parameter(Index p, const Vec3& x) const
{
    const auto center
        = [&](int i) -> Vec3 { return m_rest_centers.row(m_primitive_spheres(p, i)).transpose(); };
    switch (m_counts(p)) {
    case 1:
        return Vec3(1.0, 0.0, 0.0);
    case 2: {
        const Vec3 a = center(0), d = center(1) - a;
        const double length = d.squaredNorm();
        const double s = length > 0.0 ? std::clamp(d.dot(x - a) / length, 0.0, 1.0) : 0.0;
        return Vec3(1.0 - s, s, 0.0);
    }
    default:
        return point_triangle_closest(x, center(0), center(1), center(2)).barycentric;
    }
}

void MedialBounds::reset_outputs()
{
    const Index num_spheres = this->num_spheres();
    const Index num_primitives = this->num_primitives();
    m_handle_rotations.assign(static_cast<size_t>(num_spheres), Mat3::Identity());
    m_handle_transforms.assign(static_cast<size_t>(num_spheres), Mat3::Identity());
    m_entry_offsets.assign(m_entries.size(), Vec3::Zero());
    m_entry_grams.assign(m_entries.size(), Mat3::Zero());

    m_centers = CenterArray::Zero(num_primitives, 9);
    m_radii = MatX3::Zero(num_primitives, 3);
    m_boxes = BoxArray::Zero(num_primitives, 6);
    m_increments = VecX::Zero(num_primitives);
    m_sphere_centers = m_rest_centers;
    for (Index p = 0; p < num_primitives; ++p)
        write_primitive(p, 0.0);
}

MedialBounds::MedialBounds(const BakeData& bake)
    : MedialBounds(bake.medial, bake.collision, bake.medial_basis, bake.handle_centers,
        bake.handle_scales, bake.handle_column_offsets)
{
}

void MedialBounds::update(const Eigen::Ref<const MatX3>& q, RadiusUpdate mode)
{
    if (q.rows() != m_num_columns)
        throw_error("medial bounds: q has {} rows, expected k = {}", q.rows(), m_num_columns);
    for (Index row = 0; row < q.rows(); ++row)
        if (!q.row(row).allFinite())
            throw_error("medial bounds: row {} of q is not finite", row);
    deform_spheres(q, mode == RadiusUpdate::bound);
    tbb::parallel_for(tbb::blocked_range<Index>(0, num_primitives(), grain),
        [&](const tbb::blocked_range<Index>& range) {
            for (Index p = range.begin(); p < range.end(); ++p) {
                const double increment = mode == RadiusUpdate::lazy
                    ? 0.0
                    : bound_increment(p, q, mode == RadiusUpdate::bound);
                write_primitive(p, increment);
            }
        });
}

void MedialBounds::update_from_positions(const Eigen::Ref<const MatX3>& surface_positions,
    const Eigen::Ref<const MatX3>& sphere_centers, RadiusUpdate mode)
{
    if (surface_positions.rows() != m_num_surface_vertices
        || sphere_centers.rows() != num_spheres())
        throw_error("medial bounds: {} surface positions and {} sphere centers, expected {} and {}",
            surface_positions.rows(), sphere_centers.rows(), m_num_surface_vertices, num_spheres());
    m_sphere_centers = sphere_centers;
    tbb::parallel_for(tbb::blocked_range<Index>(0, num_primitives(), grain),
        [&](const tbb::blocked_range<Index>& range) {
            for (Index p = range.begin(); p < range.end(); ++p) {
                double increment = 0.0;
                const int count = m_counts(p);
                const int end
                    = mode == RadiusUpdate::lazy ? m_vertex_begin(p) : m_vertex_begin(p + 1);
                for (int at = m_vertex_begin(p); at < end; ++at) {
                    Vec3 center = Vec3::Zero();
                    double radius = 0.0;
                    for (int i = 0; i < count; ++i) {
                        const int s = m_primitive_spheres(p, i);
                        center += m_vertex_parameter(at, i) * m_sphere_centers.row(s).transpose();
                        radius += m_vertex_parameter(at, i) * m_rest_radii(s);
                    }
                    const double gap
                        = (surface_positions.row(m_vertices(at)).transpose() - center).norm()
                        - radius;
                    // A NaN position must not pass for "inside".
                    increment = std::isnan(gap) ? std::numeric_limits<double>::infinity()
                                                : std::max(increment, gap);
                }
                write_primitive(p, increment);
            }
        });
}

void MedialBounds::deform_spheres(const Eigen::Ref<const MatX3>& q, bool rotations)
{
    tbb::parallel_for(tbb::blocked_range<Index>(0, num_spheres(), grain),
        [&](const tbb::blocked_range<Index>& range) {
            for (Index s = range.begin(); s < range.end(); ++s) {
                Vec3 center = m_rest_centers.row(s).transpose();
                for (SparseRowMatrix::InnerIterator it(m_medial_basis, s); it; ++it)
                    center += it.value() * q.row(it.col()).transpose();
                m_sphere_centers.row(s) = center.transpose();
                if (!rotations)
                    continue;
                // F_j = I + L_j / s_j: the handle's affine map in world coordinates.
                const int offset = m_sphere_handle_offset(s);
                Mat3 transform = Mat3::Identity();
                for (int d = 0; d < 3; ++d)
                    transform.col(d)
                        += q.row(offset + 1 + d).transpose() / m_sphere_handle_scale(s);
                m_handle_transforms[static_cast<size_t>(s)] = transform;
                m_handle_rotations[static_cast<size_t>(s)] = nearest_rotation(transform);
            }
        });
}

Mat3 MedialBounds::primitive_rotation(Index p) const
{
    const auto sphere = [&](int i) { return static_cast<size_t>(m_primitive_spheres(p, i)); };
    switch (m_counts(p)) {
    case 1:
        return m_handle_rotations[sphere(0)];
    case 2: {
        // The rotation halfway between the two ends' (shortest arc).
        const Eigen::Quaterniond q0(m_handle_rotations[sphere(0)]);
        const Eigen::Quaterniond q1(m_handle_rotations[sphere(1)]);
        return q0.slerp(0.5, q1).toRotationMatrix();
    }
    default:
        return nearest_rotation(m_handle_transforms[sphere(0)] + m_handle_transforms[sphere(1)]
            + m_handle_transforms[sphere(2)]);
    }
}

// Lan et al. 2020, "deformation bounding" (docs/method.md, section 4, step 1), with sigma_max of
// each handle's whole block: delta_P = sum_j factor_j sigma_max(Q_j - Q_j^rigid(R, T)).
double MedialBounds::bound_increment(Index p, const Eigen::Ref<const MatX3>& q, bool remove_rigid)
{
    const int begin = m_entry_begin(p);
    const int end = m_entry_begin(p + 1);
    const Mat3 rotation_step
        = remove_rigid ? Mat3(primitive_rotation(p) - Mat3::Identity()) : Mat3::Zero();

    // Per entry: a_j (the constant column less (R - I) c_j) and N_j N_j^T (the other columns).
    double factor_sum = 0.0;
    Vec3 mean = Vec3::Zero();
    for (int e = begin; e < end; ++e) {
        const BoundEntry& entry = m_entries[static_cast<size_t>(e)];
        if (entry.factor == 0.0)
            continue;
        const Vec3 offset = q.row(entry.offset).transpose() - rotation_step * entry.center;
        Mat3 linear;
        for (int d = 0; d < 3; ++d)
            linear.col(d) = q.row(entry.offset + 1 + d).transpose();
        linear -= entry.scale * rotation_step;
        Mat3 gram = linear * linear.transpose();
        for (int term = 4; term < entry.terms; ++term) {
            const Vec3 column = q.row(entry.offset + term).transpose();
            gram.noalias() += column * column.transpose();
        }
        m_entry_offsets[static_cast<size_t>(e)] = offset;
        m_entry_grams[static_cast<size_t>(e)] = gram;
        factor_sum += entry.factor;
        mean += entry.factor * offset;
    }
    if (factor_sum == 0.0)
        return 0.0;

    // T: Weiszfeld iterations (majorize-minimize, monotone) on the smooth upper bound
    // sum_j factor_j sqrt(|a_j - T|^2 + |N_j|_F^2), from the factor-weighted mean of the a_j.
    Vec3 translation = Vec3::Zero();
    if (remove_rigid) {
        translation = mean / factor_sum;
        const double floor = 1e-15 * m_length;
        for (int iteration = 0; iteration < translation_iterations; ++iteration) {
            double weight_sum = 0.0;
            Vec3 weighted = Vec3::Zero();
            for (int e = begin; e < end; ++e) {
                const BoundEntry& entry = m_entries[static_cast<size_t>(e)];
                if (entry.factor == 0.0)
                    continue;
                const Vec3& offset = m_entry_offsets[static_cast<size_t>(e)];
                const double distance = std::sqrt((offset - translation).squaredNorm()
                    + m_entry_grams[static_cast<size_t>(e)].trace());
                const double weight = entry.factor / std::max(distance, floor);
                weight_sum += weight;
                weighted += weight * offset;
            }
            const Vec3 next = weighted / weight_sum;
            const double step = (next - translation).norm();
            translation = next;
            if (step <= 1e-12 * m_length)
                break;
        }
    }

    double increment = 0.0;
    for (int e = begin; e < end; ++e) {
        const BoundEntry& entry = m_entries[static_cast<size_t>(e)];
        if (entry.factor == 0.0)
            continue;
        const Vec3 column = m_entry_offsets[static_cast<size_t>(e)] - translation;
        const Mat3 gram = m_entry_grams[static_cast<size_t>(e)] + column * column.transpose();
        increment += entry.factor * std::sqrt(largest_eigenvalue_upper_bound(gram));
    }
    return increment;
}

void MedialBounds::write_primitive(Index p, double increment)
{
    m_increments(p) = increment;
    Box3 box;
    for (int i = 0; i < 3; ++i) {
        if (i >= m_counts(p)) {
            m_centers.block<1, 3>(p, 3 * i).setZero();
            m_radii(p, i) = 0.0;
            continue;
        }
        const int s = m_primitive_spheres(p, i);
        const double radius = m_rest_radii(s) + increment;
        const Vec3 center = m_sphere_centers.row(s).transpose();
        m_centers.block<1, 3>(p, 3 * i) = center.transpose();
        m_radii(p, i) = radius;
        box.extend(Box3(center - Vec3::Constant(radius), center + Vec3::Constant(radius)));
    }
    m_boxes.block<1, 3>(p, 0) = box.min().transpose();
    m_boxes.block<1, 3>(p, 3) = box.max().transpose();
}

MedialSphere MedialBounds::sphere(Index p, int i) const
{
    MAT_CHECK(p >= 0 && p < num_primitives() && i >= 0 && i < m_counts(p),
        "medial bounds: no sphere {} in primitive {}", i, p);
    return MedialSphere(m_centers.block<1, 3>(p, 3 * i).transpose(), m_radii(p, i));
}

Box3 MedialBounds::box(Index p) const
{
    MAT_CHECK(p >= 0 && p < num_primitives(), "medial bounds: no primitive {}", p);
    return Box3(m_boxes.block<1, 3>(p, 0).transpose(), m_boxes.block<1, 3>(p, 3).transpose());
}

} // namespace mat
