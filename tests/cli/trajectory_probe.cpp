// trajectory_probe FILE [FRAME]: prints "frames N last HASH" for a trajectory cache
// (formats/trajectory_io.hpp): its complete frames and an FNV-1a hash of the last frame's (or
// FRAME's) time, positions and velocities (of every object), so that shell tests compare caches
// bitwise.
// Exits 1 with one line if the file cannot be read.

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

#include "formats/trajectory_io.hpp"

namespace {
std::uint64_t fnv(std::uint64_t hash, const void* data, std::size_t bytes)
{
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i)
        hash = (hash ^ p[i]) * 1099511628211ull;
    return hash;
}
} // namespace

int main(int argc, char** argv)
{
    if (argc != 2 && argc != 3) {
        std::fprintf(stderr, "usage: trajectory_probe FILE [FRAME]\n");
        return 2;
    }
    try {
        const mat::TrajectoryReader reader(argv[1]);
        const mat::Index frames = reader.frame_count();
        const mat::Index frame = argc == 3 ? std::atol(argv[2]) : frames - 1;
        if (frames > 0 && (frame < 0 || frame >= frames)) {
            std::fprintf(
                stderr, "%s: no frame %ld (%ld frames)\n", argv[1], long(frame), long(frames));
            return 1;
        }
        std::uint64_t hash = 14695981039346656037ull;
        if (frames > 0) {
            const double time = reader.times()(frame);
            hash = fnv(hash, &time, sizeof time);
            for (mat::Index o = 0; o < reader.object_count(); ++o) {
                const mat::MatX3 x = reader.positions(o, frame);
                hash = fnv(hash, x.data(), sizeof(double) * std::size_t(x.size()));
                if (reader.has_velocities()) {
                    const mat::MatX3 v = reader.velocities(o, frame);
                    hash = fnv(hash, v.data(), sizeof(double) * std::size_t(v.size()));
                }
            }
        }
        std::printf("frames %lld last %016llx\n", static_cast<long long>(frames),
            static_cast<unsigned long long>(hash));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
    }
    return 0;
}
