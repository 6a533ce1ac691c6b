// The whole-mesh signed distance: MedialDistanceField precomputes per-primitive data once and a
// bounding-volume hierarchy of the primitives' boxes; medial_mesh_signed_distance reuses a
// per-thread field. The returned value is exactly the
// minimum over primitives of their signed distances (as medial_mesh_signed_distance): a
// subtree is skipped only when the signed distance to its box, a lower bound on the signed
// distance of everything inside, is no smaller than the best value found so far.

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include "common/medial_primitives.hpp"
#include "common/medial_primitives_kernels.hpp"

namespace mat {

namespace {
    constexpr double k_infinity = std::numeric_limits<double>::infinity();
    constexpr int k_leaf_size = 4;

    /// A key that orders like the signed distance from p to the box (a lower bound on the signed
    /// distance to anything inside) without a square root: the squared distance outside, minus
    /// the distance to the nearest face inside.
    inline double box_key(const Box3& box, const Vec3& p)
    {
        double outside2 = 0.0;
        double inside = -k_infinity;
        for (int i = 0; i < 3; ++i) {
            const double below = box.min()(i) - p(i);
            const double above = p(i) - box.max()(i);
            const double gap = std::max(below, above);
            if (gap > 0.0)
                outside2 += gap * gap;
            inside = std::max(inside, gap);
        }
        return outside2 > 0.0 ? outside2 : inside;
    }

    /// The key of a signed distance value, comparable with box_key.
    inline double distance_key(double d)
    {
        return d > 0.0 ? d * d : d;
    }
} // namespace

struct MedialDistanceField::Data {
    enum class Kind : std::uint8_t { sphere, cone, slab };
    struct Item {
        Kind kind;
        int index; ///< into spheres, cones or slabs
        Box3 box;
    };
    /// A node of the hierarchy: a leaf holds items [first, first + count), an inner node
    /// (count == 0) has children left and right.
    struct Node {
        Box3 box;
        int first = 0, count = 0;
        int left = -1, right = -1;
    };

    std::vector<MedialSphere> spheres; ///< spheres used by no primitive
    std::vector<detail::PairData> cones;
    std::vector<detail::SlabData> slabs;
    std::vector<Item> items; ///< in leaf order
    std::vector<Node> nodes; ///< nodes[0] is the root
    Box3 bounds;

    double item_distance(const Item& item, const Vec3& p) const
    {
        switch (item.kind) {
        case Kind::sphere:
            return (p - spheres[item.index].center).norm() - spheres[item.index].radius;
        case Kind::cone:
            return detail::cone_distance(cones[item.index], p).signed_distance;
        case Kind::slab:
            return slabs[item.index].distance(p).signed_distance;
        }
        return k_infinity;
    }

    /// Builds the subtree of items [first, last) by median splits along the longest axis of
    /// the box centers; returns its node index. Depth <= log2(#items) + 1.
    int build(int first, int last)
    {
        const int id = static_cast<int>(nodes.size());
        nodes.emplace_back();
        Box3 box, centers;
        for (int i = first; i < last; ++i) {
            box.extend(items[i].box);
            centers.extend(items[i].box.center());
        }
        nodes[id].box = box;
        if (last - first <= k_leaf_size) {
            nodes[id].first = first;
            nodes[id].count = last - first;
            return id;
        }
        int axis;
        centers.sizes().maxCoeff(&axis);
        const int middle = first + (last - first) / 2;
        std::nth_element(items.begin() + first, items.begin() + middle, items.begin() + last,
            [axis](const Item& a, const Item& b) {
                return a.box.center()(axis) < b.box.center()(axis);
            });
        const int left = build(first, middle);
        const int right = build(middle, last);
        nodes[id].left = left;
        nodes[id].right = right;
        return id;
    }
};

MedialDistanceField::MedialDistanceField(const MedialMesh& mesh)
{
    detail::check_mesh(mesh);
    auto data = std::make_shared<Data>();
    std::vector<char> used(mesh.num_spheres(), 0);
    for (Index i = 0; i < mesh.num_cones(); ++i) {
        const MedialCone cone = MedialCone::from_mesh(mesh, i);
        data->items.push_back({ Data::Kind::cone, int(data->cones.size()), cone.bounds() });
        data->cones.emplace_back(cone.centers[0], cone.radii[0], cone.centers[1], cone.radii[1]);
        used[mesh.cones(i, 0)] = used[mesh.cones(i, 1)] = 1;
    }
    for (Index i = 0; i < mesh.num_slabs(); ++i) {
        const MedialSlab slab = MedialSlab::from_mesh(mesh, i);
        data->items.push_back({ Data::Kind::slab, int(data->slabs.size()), slab.bounds() });
        data->slabs.emplace_back(slab.centers, slab.radii);
        used[mesh.slabs(i, 0)] = used[mesh.slabs(i, 1)] = used[mesh.slabs(i, 2)] = 1;
    }
    for (Index i = 0; i < mesh.num_spheres(); ++i) {
        if (!used[i]) {
            const MedialSphere sphere = MedialSphere::from_mesh(mesh, i);
            data->items.push_back(
                { Data::Kind::sphere, int(data->spheres.size()), sphere.bounds() });
            data->spheres.push_back(sphere);
        }
    }
    for (const Data::Item& item : data->items)
        data->bounds.extend(item.box);
    if (!data->items.empty())
        data->build(0, static_cast<int>(data->items.size()));
    m_data = std::move(data);
}

double MedialDistanceField::operator()(const Vec3& p) const
{
    const Data& data = *m_data;
    if (data.nodes.empty())
        return k_infinity;
    // Depth-first, nearer child first. The tree is balanced, so 2 entries per level suffice.
    struct Entry {
        int node;
        double key; ///< box_key of the node's box
    };
    std::array<Entry, 128> stack;
    int top = 0;
    stack[top++] = { 0, box_key(data.nodes[0].box, p) };
    double best = k_infinity;
    double best_key = k_infinity;
    while (top > 0) {
        const Entry entry = stack[--top];
        if (entry.key >= best_key)
            continue;
        const Data::Node& node = data.nodes[entry.node];
        if (node.count > 0) {
            for (int i = node.first; i < node.first + node.count; ++i) {
                const Data::Item& item = data.items[i];
                if (box_key(item.box, p) < best_key) {
                    const double d = data.item_distance(item, p);
                    if (d < best) {
                        best = d;
                        best_key = distance_key(d);
                    }
                }
            }
            continue;
        }
        const Entry left = { node.left, box_key(data.nodes[node.left].box, p) };
        const Entry right = { node.right, box_key(data.nodes[node.right].box, p) };
        if (left.key < right.key) {
            stack[top++] = right;
            stack[top++] = left;
        } else {
            stack[top++] = left;
            stack[top++] = right;
        }
    }
    return best;
}

double MedialDistanceField::signed_distance(const Eigen::Ref<const Vec3>& p) const
{
    return (*this)(Vec3(p));
}

Box3 MedialDistanceField::bounds() const
{
    return m_data->bounds;
}

namespace {
    template <typename Derived>
    bool same_array(const Eigen::DenseBase<Derived>& a, const Eigen::DenseBase<Derived>& b)
    {
        using Scalar = typename Derived::Scalar;
        return a.rows() == b.rows() && a.cols() == b.cols()
            && (a.size() == 0
                || std::memcmp(a.derived().data(), b.derived().data(), sizeof(Scalar) * a.size())
                    == 0);
    }

    bool same_mesh(const MedialMesh& a, const MedialMesh& b)
    {
        return same_array(a.centers, b.centers) && same_array(a.radii, b.radii)
            && same_array(a.cones, b.cones) && same_array(a.slabs, b.slabs);
    }
} // namespace

double medial_mesh_signed_distance(const MedialMesh& mesh, const Eigen::Ref<const Vec3>& p)
{
    // Each thread keeps the field of the last mesh it saw, with a copy of that mesh: the field is
    // reused while the mesh is bitwise equal (an O(size) memcmp, far cheaper than a rebuild).
    struct Cache {
        MedialMesh mesh;
        std::optional<MedialDistanceField> field;
    };
    thread_local Cache cache;
    if (!cache.field || !same_mesh(cache.mesh, mesh)) {
        cache.field.reset();
        MedialDistanceField field(mesh); // validates: throws before the cache is refilled
        cache.mesh = mesh;
        cache.field.emplace(std::move(field));
    }
    return (*cache.field)(Vec3(p));
}

} // namespace mat
