#include "formats/png_io.hpp"

#include <array>
#include <fstream>

#include "common/error.hpp"
#include "formats/atomic_file.hpp"

// stb_image_write: the one translation unit with its implementation. Its own code is not held to
// our warning flags.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#define STBI_WRITE_NO_STDIO
#include <stb_image_write.h>
#pragma GCC diagnostic pop

namespace mat {

namespace {

    /// stb's sink: appends to a std::ofstream.
    void write_to_stream(void* context, void* data, int size)
    {
        static_cast<std::ofstream*>(context)->write(static_cast<const char*>(data), size);
    }

} // namespace

void write_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb)
{
    if (width <= 0 || height <= 0)
        throw_error("{}: image size {} x {} is not positive", path, width, height);
    const std::size_t expected
        = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3;
    if (rgb.size() != expected)
        throw_error("{}: {} bytes of pixels for a {} x {} RGB image, expected {}", path, rgb.size(),
            width, height, expected);
    AtomicFile file(path);
    {
        std::ofstream out(file.temp_path(), std::ios::binary);
        if (!out)
            throw_error("{}: cannot open {} for writing", path, file.temp_path());
        const int ok = stbi_write_png_to_func(
            write_to_stream, &out, width, height, 3, rgb.data(), width * 3);
        out.close();
        if (ok == 0 || !out)
            throw_error("{}: cannot write the PNG image", path);
    }
    file.commit();
}

bool has_png_signature(const std::string& path)
{
    static constexpr std::array<unsigned char, 8> signature { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a,
        '\n' };
    std::ifstream in(path, std::ios::binary);
    std::array<char, 8> head {};
    if (!in.read(head.data(), head.size()))
        return false;
    for (std::size_t i = 0; i < signature.size(); ++i)
        if (static_cast<unsigned char>(head[i]) != signature[i])
            return false;
    return true;
}

} // namespace mat
