#pragma once
// Internal to formats/frame_*.cpp: what the surface, VTU and PVD frame writers share.

#include <cstdint>
#include <cstring>
#include <string>
#include <utility>

#include "common/eigen_types.hpp"

namespace mat::detail {

/// Writes `bytes` to `path` atomically (AtomicFile). Throws mat::Error naming `path`.
void write_file_atomically(const std::string& path, const std::string& bytes);

/// Checks that every coordinate is finite and every face index is in 0..#V-1; throws mat::Error
/// "<path>: cannot write <what>: vertex 12 has a non-finite coordinate" (or the face) else.
/// `positions  #V x 3`, `faces  #F x 3`.
void check_frame(const std::string& path, const char* what,
    const Eigen::Ref<const MatX3>& positions, const Eigen::Ref<const MatX3i>& faces);

/// True on a little-endian host (then binary output copies memory as it is).
inline bool host_is_little_endian()
{
    const std::uint16_t one = 1;
    unsigned char first;
    std::memcpy(&first, &one, 1);
    return first == 1;
}

/// Appends `value` to `out` as little-endian bytes, whatever the host's byte order.
template <typename T> void append_little_endian(std::string& out, T value)
{
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (!host_is_little_endian())
        for (std::size_t i = 0; i < sizeof(T) / 2; ++i)
            std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    out.append(bytes, sizeof(T));
}

} // namespace mat::detail
