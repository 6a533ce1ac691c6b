#pragma once
// PNG images (8-bit RGB), written with stb_image_write (Debian's libstb-dev). The stb header
// stays in png_io.cpp.

#include <cstdint>
#include <string>
#include <vector>

namespace mat {

/// Writes an 8-bit RGB image to `path`, atomically. `rgb` holds width * height * 3 bytes, rows
/// top to bottom, pixels left to right, channels r, g, b. Throws mat::Error naming the path if
/// the size is not positive, `rgb` has the wrong length, or the file cannot be written.
void write_png(
    const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb);

/// True if the file at `path` starts with the 8-byte PNG signature.
bool has_png_signature(const std::string& path);

} // namespace mat
