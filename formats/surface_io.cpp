#include "formats/surface_io.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <mutex>
#include <unordered_set>
#include <utility>
#include <vector>

#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "common/error.hpp"
#include "common/log.hpp"
#include "formats/surface_io_internal.hpp"
#include "formats/surface_ply.hpp"
#include "formats/surface_text_check.hpp"

namespace mat {

namespace {

    namespace fs = std::filesystem;
    using detail::RawSurface;

    /// Passes assimp's errors and warnings to our logger at debug level: they show with
    /// --log-level debug only (docs/mat-bake.md). What a user acts on is our own message: the
    /// OFF and OBJ checks (surface_text_check.hpp) or the importer's failure.
    class AssimpLogForwarder : public Assimp::LogStream {
    public:
        explicit AssimpLogForwarder(spdlog::level::level_enum level)
            : m_level(level)
        {
        }
        void write(const char* message) override
        {
            std::string text(message);
            // Drop the "Error, T0: " prefix and the trailing newline.
            const std::size_t colon = text.find(": ");
            if (colon != std::string::npos && colon < 16)
                text.erase(0, colon + 2);
            while (!text.empty() && (text.back() == '\n' || text.back() == '\r'))
                text.pop_back();
            logger().log(m_level, "assimp: {}", text);
        }

    private:
        spdlog::level::level_enum m_level;
    };

    void forward_assimp_log()
    {
        static std::once_flag once;
        std::call_once(once, [] {
            Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);
            Assimp::Logger* log = Assimp::DefaultLogger::get();
            log->attachStream(new AssimpLogForwarder(spdlog::level::debug),
                Assimp::Logger::Err | Assimp::Logger::Warn);
        });
    }

    Mat4 to_eigen(const aiMatrix4x4& m)
    {
        Mat4 out;
        out << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2,
            m.d3, m.d4;
        return out;
    }

    /// Appends the triangles of `mesh`, moved by the affine `transform` (4 x 4). A mirroring
    /// transform (negative determinant) reverses the winding so that outward stays outward.
    void append_mesh(const aiMesh& mesh, const Mat4& transform, RawSurface& raw)
    {
        const Index base = static_cast<Index>(raw.positions.size());
        const Mat3 linear = transform.topLeftCorner<3, 3>();
        const Vec3 offset = transform.topRightCorner<3, 1>();
        const bool mirrored = linear.determinant() < 0.0;
        for (unsigned i = 0; i < mesh.mNumVertices; ++i) {
            const aiVector3D& v = mesh.mVertices[i];
            raw.positions.push_back(linear * Vec3(v.x, v.y, v.z) + offset);
        }
        for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
            const aiFace& face = mesh.mFaces[f];
            if (face.mNumIndices == 1) {
                ++raw.dropped_points;
                continue;
            }
            if (face.mNumIndices == 2) {
                ++raw.dropped_lines;
                continue;
            }
            if (face.mNumIndices != 3) {
                ++raw.dropped_polygons;
                continue;
            }
            std::array<Index, 3> tri;
            bool in_range = true;
            for (int k = 0; k < 3; ++k) {
                in_range = in_range && face.mIndices[k] < mesh.mNumVertices;
                tri[k] = base + static_cast<Index>(face.mIndices[k]);
            }
            if (!in_range) {
                ++raw.dropped_polygons;
                continue;
            }
            if (mirrored)
                std::swap(tri[1], tri[2]);
            raw.faces.push_back(tri);
        }
    }

    /// Walks the node tree (iteratively, visiting each node once: a hostile file may nest
    /// deeply or loop) and appends every mesh instance in world space. Meshes no node
    /// references are appended untransformed.
    RawSurface collect_scene(const aiScene& scene)
    {
        RawSurface raw;
        std::vector<char> referenced(scene.mNumMeshes, 0);
        std::vector<std::pair<const aiNode*, Mat4>> stack;
        std::unordered_set<const aiNode*> visited;
        if (scene.mRootNode)
            stack.emplace_back(scene.mRootNode, Mat4::Identity());
        while (!stack.empty()) {
            const auto [node, parent] = stack.back();
            stack.pop_back();
            if (!visited.insert(node).second)
                continue;
            const Mat4 world = parent * to_eigen(node->mTransformation);
            for (unsigned i = 0; i < node->mNumMeshes; ++i) {
                const unsigned m = node->mMeshes[i];
                if (m >= scene.mNumMeshes || !scene.mMeshes[m])
                    continue;
                referenced[m] = 1;
                append_mesh(*scene.mMeshes[m], world, raw);
            }
            for (unsigned c = 0; c < node->mNumChildren; ++c)
                if (node->mChildren[c])
                    stack.emplace_back(node->mChildren[c], world);
        }
        for (unsigned m = 0; m < scene.mNumMeshes; ++m)
            if (!referenced[m] && scene.mMeshes[m])
                append_mesh(*scene.mMeshes[m], Mat4::Identity(), raw);
        return raw;
    }

    /// The bit pattern of a coordinate, with -0 folded onto +0, so equal positions compare equal.
    std::uint64_t coordinate_key(double x)
    {
        if (x == 0.0)
            x = 0.0;
        std::uint64_t bits;
        std::memcpy(&bits, &x, sizeof bits);
        return bits;
    }

    /// Welds vertices at exactly the same position (-0 equals +0), across meshes too, which
    /// assimp's JoinIdenticalVertices does not do; drops vertices no face uses; keeps the order
    /// of first occurrence. O(V log V).
    SurfaceMesh weld(const RawSurface& raw, const std::string& path)
    {
        const Index n = static_cast<Index>(raw.positions.size());
        if (n > std::numeric_limits<int>::max())
            throw_error("{}: cannot read surface: {} vertices exceed the supported {}", path, n,
                std::numeric_limits<int>::max());
        std::vector<char> used(n, 0);
        for (const auto& tri : raw.faces)
            for (Index v : tri)
                used[v] = 1;

        using Key = std::array<std::uint64_t, 3>;
        std::vector<std::pair<Key, Index>> keyed;
        keyed.reserve(n);
        for (Index i = 0; i < n; ++i)
            if (used[i]) {
                const Vec3& p = raw.positions[i];
                keyed.push_back(
                    { Key { coordinate_key(p.x()), coordinate_key(p.y()), coordinate_key(p.z()) },
                        i });
            }
        std::sort(keyed.begin(), keyed.end());
        std::vector<Index> representative(n, -1);
        for (std::size_t k = 0; k < keyed.size(); ++k) {
            const bool starts_group = k == 0 || keyed[k].first != keyed[k - 1].first;
            representative[keyed[k].second]
                = starts_group ? keyed[k].second : representative[keyed[k - 1].second];
        }

        std::vector<int> new_id(n, -1);
        int count = 0;
        for (Index i = 0; i < n; ++i)
            if (used[i] && representative[i] == i)
                new_id[i] = count++;
        SurfaceMesh mesh;
        mesh.positions.resize(count, 3);
        for (Index i = 0; i < n; ++i)
            if (used[i]) {
                if (representative[i] == i)
                    mesh.positions.row(new_id[i]) = raw.positions[i].transpose();
                else
                    new_id[i] = new_id[representative[i]];
            }
        mesh.faces.resize(static_cast<Index>(raw.faces.size()), 3);
        for (Index f = 0; f < mesh.faces.rows(); ++f)
            for (int k = 0; k < 3; ++k)
                mesh.faces(f, k) = new_id[raw.faces[f][k]];
        return mesh;
    }

    /// Everything but PLY goes through assimp: triangulated, per-mesh welded, then gathered.
    RawSurface read_with_assimp(const std::string& path)
    {
        if (detail::lower_extension(path) == ".obj")
            detail::check_obj_text(path);
        else
            detail::check_off_text(path);
        detail::check_glb_header(path);
        forward_assimp_log();
        Assimp::Importer importer;
        // Normals, tangents, colors and texture coordinates would keep apart the copies of a
        // vertex that formats like STL or OFF store once per face; remove them before welding.
        importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
            aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS
                | aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS);
        const unsigned flags = aiProcess_RemoveComponent | aiProcess_Triangulate
            | aiProcess_JoinIdenticalVertices | aiProcess_ValidateDataStructure;
        const aiScene* scene = nullptr;
        try {
            scene = importer.ReadFile(path, flags);
        } catch (const std::exception& e) {
            throw_error("{}: cannot read surface: {}", path, e.what());
        } catch (...) {
            throw_error("{}: cannot read surface: unknown failure in the importer", path);
        }
        if (!scene) {
            // Our own line for the failures assimp reports without a place (surface_text_check).
            const std::string explained = detail::explain_import_failure(path);
            if (!explained.empty())
                throw Error(explained);
            const std::string reason = importer.GetErrorString();
            throw_error(
                "{}: cannot read surface: {}", path, reason.empty() ? "unknown error" : reason);
        }
        return collect_scene(*scene);
    }

} // namespace

SurfaceMesh read_surface(const std::string& path)
{
    std::error_code ec;
    if (!fs::exists(path, ec))
        throw_error("{}: cannot read surface: no such file", path);
    if (fs::is_directory(path, ec))
        throw_error("{}: cannot read surface: it is a directory", path);

    // assimp 5.2's PLY loader can hang or crash on a malformed file: PLY never reaches it.
    const RawSurface raw = detail::lower_extension(path) == ".ply" || detail::has_ply_magic(path)
        ? detail::read_ply(path)
        : read_with_assimp(path);
    if (raw.dropped_points + raw.dropped_lines + raw.dropped_polygons > 0)
        logger().warn("{}: dropped {} points, {} lines and {} other non-triangle primitives", path,
            raw.dropped_points, raw.dropped_lines, raw.dropped_polygons);
    if (raw.faces.empty())
        throw_error("{}: cannot read surface: the file holds no triangle", path);
    SurfaceMesh mesh = weld(raw, path);
    logger().debug("{}: read {} vertices, {} faces", path, mesh.num_vertices(), mesh.num_faces());
    return mesh;
}

} // namespace mat
