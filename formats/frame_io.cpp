// Surface frames (.obj, .ply) and the helpers every frame writer shares.

#include "formats/frame_io.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "common/error.hpp"
#include "formats/atomic_file.hpp"
#include "formats/frame_io_internal.hpp"

namespace mat {

namespace detail {

    void write_file_atomically(const std::string& path, const std::string& bytes)
    {
        AtomicFile atomic(path);
        {
            std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(
                std::fopen(atomic.temp_path().c_str(), "wb"), std::fclose);
            if (!file)
                throw_error("{}: cannot write: {}", path, std::strerror(errno));
            const bool written = bytes.empty()
                || std::fwrite(bytes.data(), 1, bytes.size(), file.get()) == bytes.size();
            const int write_errno = errno;
            const int status = std::fclose(file.release());
            if (!written || status != 0)
                throw_error(
                    "{}: cannot write: {}", path, std::strerror(written ? errno : write_errno));
        }
        atomic.commit();
    }

    void check_frame(const std::string& path, const char* what,
        const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3i>& faces)
    {
        for (Index i = 0; i < positions.rows(); ++i)
            if (!positions.row(i).allFinite())
                throw_error("{}: cannot write {}: vertex {} has a non-finite coordinate ({}, {}, "
                            "{})",
                    path, what, i, positions(i, 0), positions(i, 1), positions(i, 2));
        const Index num_vertices = positions.rows();
        for (Index f = 0; f < faces.rows(); ++f)
            for (int k = 0; k < 3; ++k)
                if (faces(f, k) < 0 || faces(f, k) >= num_vertices)
                    throw_error("{}: cannot write {}: face {} has vertex index {}, expected 0 to "
                                "{}",
                        path, what, f, faces(f, k), num_vertices - 1);
    }

} // namespace detail

namespace {

    std::string obj_text(
        const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3i>& faces)
    {
        // fmt's "{}" prints the shortest text that reads back to the same double, several
        // times faster than printf's %.17g (and shorter).
        fmt::memory_buffer out;
        fmt::format_to(
            fmt::appender(out), "# {} vertices, {} faces\n", positions.rows(), faces.rows());
        for (Index i = 0; i < positions.rows(); ++i)
            fmt::format_to(fmt::appender(out), "v {} {} {}\n", positions(i, 0), positions(i, 1),
                positions(i, 2));
        for (Index f = 0; f < faces.rows(); ++f)
            fmt::format_to(fmt::appender(out), "f {} {} {}\n", faces(f, 0) + 1, faces(f, 1) + 1,
                faces(f, 2) + 1);
        return fmt::to_string(out);
    }

    std::string ply_bytes(
        const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3i>& faces)
    {
        std::string out = fmt::format("ply\nformat binary_little_endian 1.0\n"
                                      "comment medial elastics frame\nelement vertex {}\n"
                                      "property double x\nproperty double y\nproperty double z\n"
                                      "element face {}\nproperty list uchar int vertex_indices\n"
                                      "end_header\n",
            positions.rows(), faces.rows());
        out.reserve(
            out.size() + std::size_t(positions.rows()) * 24 + std::size_t(faces.rows()) * 13);
        for (Index i = 0; i < positions.rows(); ++i)
            for (int k = 0; k < 3; ++k)
                detail::append_little_endian(out, positions(i, k));
        for (Index f = 0; f < faces.rows(); ++f) {
            out.push_back(char(3));
            for (int k = 0; k < 3; ++k)
                detail::append_little_endian(out, std::int32_t(faces(f, k)));
        }
        return out;
    }

} // namespace

const char* extension(SurfaceFrameFormat format)
{
    return format == SurfaceFrameFormat::obj ? "obj" : "ply";
}

SurfaceFrameFormat parse_surface_frame_format(const std::string& name)
{
    std::string lower = name;
    for (char& c : lower)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    if (lower == "obj")
        return SurfaceFrameFormat::obj;
    if (lower == "ply")
        return SurfaceFrameFormat::ply;
    throw_error("unknown surface frame format '{}' (expected obj or ply)", name);
}

void write_frame_surface(const std::string& path, const Eigen::Ref<const MatX3>& positions,
    const Eigen::Ref<const MatX3i>& faces, SurfaceFrameFormat format)
{
    detail::check_frame(path, "surface frame", positions, faces);
    detail::write_file_atomically(path,
        format == SurfaceFrameFormat::obj ? obj_text(positions, faces)
                                          : ply_bytes(positions, faces));
}

} // namespace mat
