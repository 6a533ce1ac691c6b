#include "common/cli.hpp"

#include <charconv>
#include <cstdio>
#include <exception>
#include <limits>
#include <string>
#include <system_error>

#include "common/error.hpp"
#include "common/log.hpp"
#include "common/parallel.hpp"
#include "common/version.hpp"

namespace mat {

CLI::Validator whole_number_in(long long min, long long max)
{
    const std::string description = max == std::numeric_limits<long long>::max()
        ? fmt::format("INT >= {}", min)
        : fmt::format("INT in {}..{}", min, max);
    return CLI::Validator(
        [min, max](std::string& input) -> std::string {
            long long value = 0;
            const char* end = input.data() + input.size();
            const auto [stop, error] = std::from_chars(input.data(), end, value);
            if (input.empty() || error == std::errc::invalid_argument || stop != end)
                return fmt::format("must be a whole number, got '{}'", input);
            if (error == std::errc::result_out_of_range || value < min || value > max) {
                if (max == std::numeric_limits<long long>::max())
                    return fmt::format("must be at least {}, got {}", min, input);
                return fmt::format("must be from {} to {}, got {}", min, max, input);
            }
            return std::string();
        },
        description);
}

CLI::Validator whole_number_at_least(long long min)
{
    return whole_number_in(min, std::numeric_limits<long long>::max());
}

void add_common_options(CLI::App& app, CommonOptions& options)
{
    app.set_version_flag("--version", std::string(app.get_name()) + " " + version_string);
    app.add_option(
           "--log-level", options.log_level, std::string("Logging level: ") + log_level_names())
        ->capture_default_str();
    app.add_option("--threads", options.threads, "Worker threads (0: all cores)")
        ->capture_default_str()
        ->check(whole_number_in(0, 4096));
}

void apply_common_options(const CommonOptions& options)
{
    set_log_level(options.log_level);
    set_threads(options.threads);
}

int run_cli(CLI::App& app, int argc, char** argv, const std::function<void()>& body)
{
    const std::string tool = app.get_name();
    try {
        app.parse(argc, argv);
        body();
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // Also thrown by a body that finds the arguments incomplete.
        std::fprintf(stderr, "%s: usage error: %s\nRun '%s --help' for the options.\n",
            tool.c_str(), e.what(), tool.c_str());
        return 2;
    } catch (const Error& e) {
        std::fprintf(stderr, "%s: error: %s\n", tool.c_str(), e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "%s: error: out of memory\n", tool.c_str());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: error: %s\n", tool.c_str(), e.what());
        return 1;
    }
    return 0;
}

} // namespace mat
