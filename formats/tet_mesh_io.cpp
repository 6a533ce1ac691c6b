#include "formats/tet_mesh_io.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/tet_geometry.hpp"
#include "formats/atomic_file.hpp"
#include "formats/tet_mesh_io_detail.hpp"
#include "formats/text_io.hpp"

namespace mat {

namespace tet_mesh_io_detail {

    bool iequals(std::string_view a, std::string_view b)
    {
        return a.size() == b.size()
            && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
                   return std::tolower(static_cast<unsigned char>(x))
                       == std::tolower(static_cast<unsigned char>(y));
               });
    }

    bool ends_with(std::string_view text, std::string_view suffix)
    {
        return text.size() >= suffix.size()
            && iequals(text.substr(text.size() - suffix.size()), suffix);
    }

    TetMesh finish(const RawTets& raw, const std::string& name)
    {
        TetMesh mesh;
        mesh.positions = Eigen::Map<const MatX3>(
            raw.positions.data(), static_cast<Index>(raw.positions.size() / 3), 3);
        mesh.tets
            = Eigen::Map<const MatX4i>(raw.tets.data(), static_cast<Index>(raw.tets.size() / 4), 4);
        Index flipped = 0, flat = 0;
        for (Index t = 0; t < mesh.num_tets(); ++t) {
            const double det = tet_orientation(mesh, t);
            if (det < 0.0) {
                std::swap(mesh.tets(t, 2), mesh.tets(t, 3));
                ++flipped;
            } else if (!(det > 0.0)) {
                ++flat;
            }
        }
        if (flipped > 0)
            logger().info("{}: {} of {} tets were negatively oriented; reordered them", name,
                flipped, mesh.num_tets());
        if (flat > 0)
            logger().warn("{}: {} tets have zero volume", name, flat);
        logger().debug("{}: read {} vertices, {} tets", name, mesh.num_vertices(), mesh.num_tets());
        return mesh;
    }

    void validate(const TetMesh& mesh, const std::string& name)
    {
        const Index n = mesh.num_vertices();
        for (Index i = 0; i < n; ++i)
            if (!mesh.positions.row(i).allFinite())
                throw_error("{}: cannot write: vertex {} has a non-finite position", name, i);
        for (Index t = 0; t < mesh.num_tets(); ++t)
            for (int k = 0; k < 4; ++k) {
                const int v = mesh.tets(t, k);
                if (v < 0 || v >= n)
                    throw_error(
                        "{}: cannot write: tet {} has vertex index {} out of range (#V = {})", name,
                        t, v, n);
                for (int m = 0; m < k; ++m)
                    if (mesh.tets(t, m) == v)
                        throw_error("{}: cannot write: tet {} repeats vertex index {}", name, t, v);
            }
    }

    void write_atomic(const std::string& path, const std::string& text)
    {
        AtomicFile file(path);
        text_io::write_file(file.temp_path(), text, path);
        file.commit();
    }

} // namespace tet_mesh_io_detail

using tet_mesh_io_detail::ends_with;

TetMesh read_tet_mesh(const std::string& path)
{
    if (ends_with(path, ".mesh"))
        return read_medit(path);
    if (ends_with(path, ".node") || ends_with(path, ".ele"))
        return read_tetgen(path);
    throw_error(
        "{}: unknown tet mesh format: expected a .mesh (Medit) or .node/.ele (TetGen) file", path);
}

void write_tet_mesh(const std::string& path, const TetMesh& mesh)
{
    if (ends_with(path, ".mesh"))
        return write_medit(path, mesh);
    if (ends_with(path, ".node") || ends_with(path, ".ele"))
        return write_tetgen(path, mesh);
    throw_error(
        "{}: unknown tet mesh format: expected a .mesh (Medit) or .node/.ele (TetGen) file", path);
}

} // namespace mat
