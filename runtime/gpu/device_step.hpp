#pragma once
// The semi-reduced projective dynamics step on a CUDA GPU (docs/gpu.md): every tet's local step,
// the right-hand side gathered per node, B^T y in the handle form, the explicit S^-1 times the
// three right-hand sides, and x = X + B q, with the body's state kept on the GPU. PdSolver
// (runtime/pd/solver.hpp) drives it for `--device cuda`; a step with contact candidates brings
// q to the CPU's contact stage and back in every iteration (which parts run where: docs/gpu.md).
//
// This header has no CUDA types. Without -DMAT_CUDA=ON the engine underneath is
// device_engine_none.cpp's, and the constructor throws mat::Error saying so.

#include <memory>
#include <string>
#include <vector>

#include "common/eigen_types.hpp"
#include "runtime/model.hpp"
#include "runtime/pd/contact.hpp"

namespace mat {

namespace gpu {
    class Engine;
}

/// Seconds per phase of the device step, measured with CUDA events when profiling is on (each
/// phase then ends with an event; off, the phases stay 0 and only the transfers are timed, from
/// the host).
struct DeviceTimings {
    double local = 0.0; ///< projections and their shares
    double gather = 0.0; ///< per node: base + its corners' shares
    double rhs = 0.0; ///< B^T y
    double solve = 0.0; ///< S^-1 times the three right-hand sides
    double reconstruct = 0.0; ///< x = X + B q
    double begin_end = 0.0; ///< inertia and base at the start, velocities at the end
    double upload = 0.0; ///< the state to the GPU (host time)
    double download = 0.0; ///< positions and velocities back (host time)
    long steps = 0;
};

/// Why CUDA cannot be used here ("" if a device is usable): built without CUDA, no device, or
/// the driver's error.
std::string cuda_unavailable_reason();

class DeviceSemiStep {
public:
    /// Uploads the model (tets, Dm^-1, volumes, masses, the basis in handle form, S^-1, A X,
    /// pins, `planes`). Throws mat::Error if CUDA is unavailable, the basis is not in handle
    /// form, or the GPU's memory does not suffice. `gravity` in m/s^2, `damping` as the solver's.
    /// `exact_projections`: the decomposition of SolverOptions::exact_projections.
    DeviceSemiStep(const Model& model, const Vec3& gravity, double damping, int iterations,
        const std::vector<PlaneCollider>& planes, bool exact_projections = false);
    ~DeviceSemiStep();
    DeviceSemiStep(const DeviceSemiStep&) = delete;
    DeviceSemiStep& operator=(const DeviceSemiStep&) = delete;

    /// x_n, v_n  n x 3 to the GPU. Without it, a step starts where the last one ended there.
    void upload_state(const MatX3& positions, const MatX3& velocities);
    /// Start of a step: the pin targets  #pinned x 3 in; s = x_n + h v_n + h^2 g and the step's
    /// constant right-hand side on the GPU; with planes, each plane's nearest node at x_n or s.
    void begin_step(const MatX3& pin_targets);
    /// Per plane, the smallest signed distance of a node at x_n or at s (the last begin_step's).
    const std::vector<double>& plane_minima() const;
    /// One iteration's local step and reduced solve: q on the GPU.
    void iterate();
    /// Every iteration of the step (iterate + reconstruct each), launched as one CUDA graph.
    void iterate_all();
    /// q  k x 3 to the host / from the host (the CPU contact stage's view of the solve).
    void download_q(MatX& q);
    void upload_q(const MatX& q);
    /// x = X + B q on the GPU.
    void reconstruct();
    /// The step's positions so far  n x 3 to the host (waits for the GPU).
    void download_positions(MatX3& positions);
    /// End of a step: v = (1 - damping) (x - x_n) / h, and x is the next step's x_n, on the GPU.
    void end_step();
    /// The state the last end_step() left  n x 3 each, to the host (waits for the GPU).
    void download_state(MatX3& positions, MatX3& velocities);

    /// With `on`, each phase is timed with CUDA events (costs a few microseconds per phase).
    void set_profiling(bool on);
    const DeviceTimings& timings() const { return m_timings; }
    /// The device's name and memory, for logs.
    std::string description() const;

private:
    std::unique_ptr<gpu::Engine> m_impl;
    DeviceTimings m_timings;
    MatX3 m_q_rows; ///< q  k x 3 row-major, the engine's layout

    /// Adds the engine's profiled phases since the last call to m_timings.
    void collect_phases();
};

} // namespace mat
