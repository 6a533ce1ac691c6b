#include "common/parallel.hpp"

#include <memory>

#include <tbb/global_control.h>
#include <tbb/info.h>

#include "common/error.hpp"

namespace mat {

namespace {
    std::unique_ptr<tbb::global_control>& control()
    {
        static std::unique_ptr<tbb::global_control> instance;
        return instance;
    }
} // namespace

void set_threads(int n)
{
    if (n < 0)
        throw_error("--threads must be >= 0 (0 means all cores), got {}", n);
    control().reset();
    if (n > 0)
        control() = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, static_cast<size_t>(n));
}

int thread_count()
{
    return static_cast<int>(
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

} // namespace mat
