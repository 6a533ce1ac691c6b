// Helpers shared by the fuzz targets (tests/fuzz/fuzz_support.hpp).

#include "tests/fuzz/fuzz_support.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "common/log.hpp"

namespace mat::fuzz {

namespace fs = std::filesystem;

void quiet_logger()
{
    static const bool done = (logger().set_level(spdlog::level::off), true);
    (void)done;
}

void check(bool condition, const char* target, const char* what)
{
    if (!condition) {
        std::fprintf(stderr, "%s: invariant broken: %s\n", target, what);
        std::abort();
    }
}

namespace {
    struct Scratch {
        std::string path;
        Scratch()
        {
            std::error_code ec;
            const fs::path base = fs::is_directory("/dev/shm", ec) && access("/dev/shm", W_OK) == 0
                ? fs::path("/dev/shm")
                : fs::temp_directory_path();
            path = (base / ("mat-fuzz-" + std::to_string(getpid()))).string();
            fs::create_directories(path);
        }
        ~Scratch()
        {
            std::error_code ec;
            fs::remove_all(path, ec);
        }
    };
} // namespace

const std::string& scratch_folder()
{
    static const Scratch scratch;
    return scratch.path;
}

std::string write_scratch(const std::string& name, std::string_view bytes)
{
    const std::string path = scratch_folder() + "/" + name;
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.close();
    if (!out) {
        std::fprintf(stderr, "fuzz: cannot write the scratch file %s\n", path.c_str());
        std::abort();
    }
    return path;
}

} // namespace mat::fuzz
