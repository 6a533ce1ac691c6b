// The engine of a build without CUDA (-DMAT_CUDA=OFF, the default): every use says so.

#include <stdexcept>

#include "runtime/gpu/device_engine.hpp"

namespace mat::gpu {

namespace {
    constexpr const char* not_built
        = "this build has no CUDA support (configure with -DMAT_CUDA=ON; docs/gpu.md)";
}

// No engine is ever made: the constructor throws, and the other members are never reached.
struct Engine::Impl { };

Engine::Engine(const EngineModel& /*model*/)
{
    throw std::runtime_error(not_built);
}
Engine::~Engine() = default;
void Engine::upload_state(const double*, const double*)
{
}
void Engine::begin_step(const double*)
{
}
const std::vector<double>& Engine::plane_minima() const
{
    static const std::vector<double> none;
    return none;
}
void Engine::iterate()
{
}
void Engine::iterate_all()
{
}
void Engine::download_q(double*)
{
}
void Engine::upload_q(const double*)
{
}
void Engine::reconstruct()
{
}
void Engine::download_positions(double*)
{
}
void Engine::end_step()
{
}
void Engine::download_state(double*, double*)
{
}
void Engine::set_profiling(bool)
{
}
EnginePhases Engine::take_phases()
{
    return {};
}
std::string Engine::description() const
{
    return {};
}

std::string engine_unavailable_reason()
{
    return not_built;
}

} // namespace mat::gpu
