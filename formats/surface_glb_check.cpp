// The check of binary glTF (GLB) chunk lengths before assimp reads the file
// (formats/surface_io_internal.hpp; docs/mat-bake.md, Inputs).

#include <cstdint>
#include <filesystem>
#include <fstream>

#include "common/error.hpp"
#include "formats/surface_io_internal.hpp"

namespace mat::detail {

namespace {
    bool read_u32(std::ifstream& in, std::uint32_t& value)
    {
        unsigned char bytes[4];
        if (!in.read(reinterpret_cast<char*>(bytes), 4))
            return false;
        value = std::uint32_t(bytes[0]) | std::uint32_t(bytes[1]) << 8
            | std::uint32_t(bytes[2]) << 16 | std::uint32_t(bytes[3]) << 24;
        return true;
    }
} // namespace

void check_glb_header(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    char magic[4] = {};
    std::uint32_t version = 0, length = 0;
    if (!in.read(magic, 4) || std::string(magic, 4) != "glTF" || !read_u32(in, version)
        || !read_u32(in, length))
        return; // not a GLB, or too short to be one: assimp says what it is
    std::error_code ec;
    const std::uint64_t size = std::filesystem::file_size(path, ec);
    if (ec)
        throw_error("{}: cannot read surface: {}", path, ec.message());
    if (version == 1) { // one content chunk: length, format, then the JSON
        std::uint32_t content = 0, format = 0;
        if (read_u32(in, content) && read_u32(in, format) && content > size - 20)
            throw_error("{}: GLB chunk 0 (content) claims {} bytes but {} follow its header", path,
                content, size - 20);
        return;
    }
    std::uint64_t offset = 12;
    for (int chunk = 0; offset + 8 <= size; ++chunk) {
        std::uint32_t chunk_length = 0, type = 0;
        if (!read_u32(in, chunk_length) || !read_u32(in, type))
            return;
        if (chunk_length > size - offset - 8)
            throw_error("{}: GLB chunk {} claims {} bytes but {} follow its header", path, chunk,
                chunk_length, size - offset - 8);
        offset += 8 + std::uint64_t(chunk_length);
        in.seekg(std::streamoff(offset));
    }
}

} // namespace mat::detail
