#include "formats/surface_io.hpp"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "common/error.hpp"
#include "formats/atomic_file.hpp"
#include "formats/surface_io_internal.hpp"

namespace mat {

namespace {

    /// Little-endian binary output collected in memory, independent of the host's byte order.
    class LittleEndianBuffer {
    public:
        void text(const std::string& s) { m_bytes.insert(m_bytes.end(), s.begin(), s.end()); }
        void u8(std::uint8_t v) { m_bytes.push_back(static_cast<char>(v)); }
        void u16(std::uint16_t v) { put(v, 2); }
        void u32(std::uint32_t v) { put(v, 4); }
        void i32(std::int32_t v) { put(static_cast<std::uint32_t>(v), 4); }
        void f32(float v)
        {
            std::uint32_t bits;
            std::memcpy(&bits, &v, sizeof bits);
            put(bits, 4);
        }
        void f64(double v)
        {
            std::uint64_t bits;
            std::memcpy(&bits, &v, sizeof bits);
            put(bits, 8);
        }
        const std::vector<char>& bytes() const { return m_bytes; }

    private:
        void put(std::uint64_t v, int n)
        {
            for (int i = 0; i < n; ++i)
                m_bytes.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
        }
        std::vector<char> m_bytes;
    };

    /// An open stdio file that closes itself; close() reports write errors.
    class OutputFile {
    public:
        OutputFile(const std::string& temp, const std::string& target)
            : m_file(std::fopen(temp.c_str(), "wb"))
            , m_target(target)
        {
            if (!m_file)
                throw_error("{}: cannot write: {}", m_target, std::strerror(errno));
        }
        ~OutputFile()
        {
            if (m_file)
                std::fclose(m_file);
        }
        OutputFile(const OutputFile&) = delete;
        OutputFile& operator=(const OutputFile&) = delete;

        std::FILE* get() const { return m_file; }
        void write(const std::vector<char>& bytes)
        {
            if (!bytes.empty()
                && std::fwrite(bytes.data(), 1, bytes.size(), m_file) != bytes.size())
                throw_error("{}: cannot write: {}", m_target, std::strerror(errno));
        }
        void close()
        {
            const bool failed = std::ferror(m_file) != 0;
            const int status = std::fclose(m_file);
            m_file = nullptr;
            if (failed || status != 0)
                throw_error("{}: cannot write: {}", m_target, std::strerror(errno));
        }

    private:
        std::FILE* m_file;
        std::string m_target;
    };

    void write_obj(std::FILE* file, const SurfaceMesh& mesh)
    {
        std::fprintf(file, "# %lld vertices, %lld faces\n",
            static_cast<long long>(mesh.num_vertices()), static_cast<long long>(mesh.num_faces()));
        for (Index i = 0; i < mesh.num_vertices(); ++i)
            std::fprintf(file, "v %.17g %.17g %.17g\n", mesh.positions(i, 0), mesh.positions(i, 1),
                mesh.positions(i, 2));
        for (Index f = 0; f < mesh.num_faces(); ++f)
            std::fprintf(file, "f %d %d %d\n", mesh.faces(f, 0) + 1, mesh.faces(f, 1) + 1,
                mesh.faces(f, 2) + 1);
    }

    void write_off(std::FILE* file, const SurfaceMesh& mesh)
    {
        std::fprintf(file, "OFF\n%lld %lld 0\n", static_cast<long long>(mesh.num_vertices()),
            static_cast<long long>(mesh.num_faces()));
        for (Index i = 0; i < mesh.num_vertices(); ++i)
            std::fprintf(file, "%.17g %.17g %.17g\n", mesh.positions(i, 0), mesh.positions(i, 1),
                mesh.positions(i, 2));
        for (Index f = 0; f < mesh.num_faces(); ++f)
            std::fprintf(
                file, "3 %d %d %d\n", mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2));
    }

    std::vector<char> ply_bytes(const SurfaceMesh& mesh)
    {
        LittleEndianBuffer out;
        out.text(fmt::format("ply\nformat binary_little_endian 1.0\ncomment medial elastics\n"
                             "element vertex {}\nproperty double x\nproperty double y\n"
                             "property double z\nelement face {}\n"
                             "property list uchar int vertex_indices\nend_header\n",
            mesh.num_vertices(), mesh.num_faces()));
        for (Index i = 0; i < mesh.num_vertices(); ++i)
            for (int k = 0; k < 3; ++k)
                out.f64(mesh.positions(i, k));
        for (Index f = 0; f < mesh.num_faces(); ++f) {
            out.u8(3);
            for (int k = 0; k < 3; ++k)
                out.i32(mesh.faces(f, k));
        }
        return out.bytes();
    }

    std::vector<char> stl_bytes(const SurfaceMesh& mesh, const std::string& path)
    {
        if (mesh.num_faces() > std::numeric_limits<std::uint32_t>::max())
            throw_error(
                "{}: cannot write: {} faces exceed binary STL's limit", path, mesh.num_faces());
        LittleEndianBuffer out;
        // The 80-byte header must not start with "solid", or readers take the file for ASCII.
        std::string header = "binary STL written by medial elastics";
        header.resize(80, ' ');
        out.text(header);
        out.u32(static_cast<std::uint32_t>(mesh.num_faces()));
        for (Index f = 0; f < mesh.num_faces(); ++f) {
            const Vec3 a = mesh.positions.row(mesh.faces(f, 0));
            const Vec3 b = mesh.positions.row(mesh.faces(f, 1));
            const Vec3 c = mesh.positions.row(mesh.faces(f, 2));
            Vec3 normal = (b - a).cross(c - a);
            const double length = normal.norm();
            normal = length > 0.0 ? Vec3(normal / length) : Vec3::Zero();
            for (const Vec3& v : { normal, a, b, c })
                for (int k = 0; k < 3; ++k)
                    out.f32(static_cast<float>(v[k]));
            out.u16(0);
        }
        return out.bytes();
    }

} // namespace

void write_surface(const std::string& path, const SurfaceMesh& mesh)
{
    const std::string ext = detail::lower_extension(path);
    if (ext != ".obj" && ext != ".off" && ext != ".ply" && ext != ".stl")
        throw_error("{}: cannot write surface: unknown extension '{}' (expected .obj, .off, .ply "
                    "or .stl)",
            path, ext);
    for (Index f = 0; f < mesh.num_faces(); ++f)
        for (int k = 0; k < 3; ++k)
            if (mesh.faces(f, k) < 0 || mesh.faces(f, k) >= mesh.num_vertices())
                throw_error("{}: cannot write surface: face {} has vertex index {}, expected 0 to "
                            "{}",
                    path, f, mesh.faces(f, k), mesh.num_vertices() - 1);

    AtomicFile atomic(path);
    {
        OutputFile file(atomic.temp_path(), path);
        if (ext == ".obj")
            write_obj(file.get(), mesh);
        else if (ext == ".off")
            write_off(file.get(), mesh);
        else if (ext == ".ply")
            file.write(ply_bytes(mesh));
        else
            file.write(stl_bytes(mesh, path));
        file.close();
    }
    atomic.commit();
}

} // namespace mat
