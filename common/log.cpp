#include "common/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include "common/error.hpp"

namespace mat {

spdlog::logger& logger()
{
    static std::shared_ptr<spdlog::logger> instance = [] {
        auto created = spdlog::stderr_color_mt("mat");
        created->set_pattern("[%l] %v");
        created->set_level(spdlog::level::info);
        return created;
    }();
    return *instance;
}

void set_log_level(const std::string& level)
{
    const auto parsed = spdlog::level::from_str(level);
    // from_str maps unknown names to "off"; only "off" itself may mean off.
    if (parsed == spdlog::level::off && level != "off")
        throw_error("unknown log level '{}' (expected one of: {})", level, log_level_names());
    logger().set_level(parsed);
}

const char* log_level_names()
{
    return "trace, debug, info, warn, error, critical, off";
}

} // namespace mat
