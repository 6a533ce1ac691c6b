#pragma once
// Helpers shared by the fuzz targets (docs/building.md, Fuzzing): silencing the logger, a
// checked invariant that aborts (libFuzzer and the regression driver both report an abort), and
// a scratch folder in /dev/shm for the readers that take a path.

#include <cstdint>
#include <string>
#include <string_view>

namespace mat::fuzz {

/// Turns the logger off once (warnings about odd input are expected, not findings).
void quiet_logger();

/// Aborts with "<target>: invariant broken: <what>" unless `condition` holds.
void check(bool condition, const char* target, const char* what);

/// A per-process scratch folder (/dev/shm if writable, else the temporary folder), created on
/// first use and removed at exit.
const std::string& scratch_folder();

/// Writes `bytes` to `<scratch folder>/<name>` (replacing it) and returns the path.
std::string write_scratch(const std::string& name, std::string_view bytes);

/// The input as text.
inline std::string_view as_text(const std::uint8_t* data, std::size_t size)
{
    return std::string_view(reinterpret_cast<const char*>(data), size);
}

} // namespace mat::fuzz
