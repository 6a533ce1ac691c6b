#pragma once
// The one logger. Libraries log through it (never std::cout); it writes to stderr so that
// stdout stays free for a command's own output.

#include <string>

#include <spdlog/spdlog.h>

namespace mat {

/// The project's logger ("mat"), created on first use, writing to stderr.
spdlog::logger& logger();

/// Sets the level from its name: trace, debug, info, warn, error, critical, off.
/// Throws mat::Error on an unknown name.
void set_log_level(const std::string& level);

/// The accepted level names, for --help texts and validators.
const char* log_level_names();

} // namespace mat
