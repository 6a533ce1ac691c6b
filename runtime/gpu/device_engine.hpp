#pragma once
// The GPU side of DeviceSemiStep (runtime/gpu/device_step.hpp), in plain arrays: the model as
// the kernels read it, and the engine that owns the device memory, the stream and the kernels
// (runtime/gpu/device_engine.cu). Built without CUDA, device_engine_none.cpp stands in: every
// engine throws std::runtime_error saying so. No Eigen, fmt or project headers cross into the
// CUDA translation unit but device_math.hpp.

#include <memory>
#include <string>
#include <vector>

#include "runtime/gpu/device_math.hpp"

namespace mat::gpu {

/// The model in the kernels' layout. Matrices are row-major; n nodes, T tets, k basis columns, m
/// handles, P pins, E (node, handle) entries of the basis.
struct EngineModel {
    int nodes = 0;
    int tets = 0;
    int columns = 0;
    int handles = 0;
    double time_step = 0.0;
    double damping = 0.0;
    double gravity[3] = { 0.0, 0.0, 0.0 };
    int iterations = 1;
    ProjectionWeights weights;
    std::vector<int> tet_nodes; ///< 4 T
    std::vector<double> dm_inverse; ///< 9 T, tet by tet
    std::vector<double> volumes; ///< T
    std::vector<int> incident_offsets; ///< n + 1: node i's corners (4 tet + corner), sorted
    std::vector<int> incident_corners;
    std::vector<double> rest; ///< 3 n
    std::vector<double> mass_over_h2; ///< n: m_i / h^2
    std::vector<double> rest_system; ///< 3 n: A X
    std::vector<int> pin_nodes; ///< P
    double pin_weight = 0.0;
    // The basis in handle form: B(i, off_j + t) = w_ij p_t((X_i - c_j) / s_j).
    std::vector<double> handle_centers; ///< 3 m
    std::vector<double> handle_inverse_scales; ///< m: 1 / s_j
    std::vector<int> handle_offsets; ///< m: first column
    std::vector<int> handle_terms; ///< m: 4 or 10
    std::vector<int> node_entry_offsets; ///< n + 1: node i's entries, by handle
    std::vector<int> node_entry_handles; ///< E
    std::vector<double> node_entry_weights; ///< E
    std::vector<int> handle_entry_offsets; ///< m + 1: handle j's entries, by node
    std::vector<int> handle_entry_nodes; ///< E
    std::vector<double> handle_entry_weights; ///< E
    std::vector<double> inverse; ///< k x k: S^-1
    /// Ground planes: unit normal and n . p of a point p on it, 4 doubles each.
    std::vector<double> planes;
};

/// Seconds per phase (CUDA events), when profiling.
struct EnginePhases {
    double local = 0.0, gather = 0.0, rhs = 0.0, solve = 0.0, reconstruct = 0.0, begin_end = 0.0;
};

class Engine {
public:
    /// Uploads `model`. Throws std::runtime_error (CUDA's message) on failure.
    explicit Engine(const EngineModel& model);
    ~Engine();
    Engine(const Engine&) = delete;
    Engine& operator=(const Engine&) = delete;

    /// x_n, v_n (3 n each) to the GPU (else a step starts from the last step's end there).
    void upload_state(const double* positions, const double* velocities);
    /// The pin targets (3 P) in; s and the base on the GPU. With planes, also each plane's
    /// smallest signed distance of a node at x_n or at s (waits for it): plane_minima().
    void begin_step(const double* pins);
    const std::vector<double>& plane_minima() const;
    void iterate();
    /// iterations x (iterate + reconstruct), as one CUDA graph.
    void iterate_all();
    void download_q(double* q); ///< 3 k, row-major
    void upload_q(const double* q);
    void reconstruct();
    void download_positions(double* x); ///< the step's positions so far, 3 n
    /// v = (1 - damping) (x - x_n) / h, and x becomes the next step's x_n (nothing waits).
    void end_step();
    /// The state the last end_step() left: positions and velocities, 3 n each (waits).
    void download_state(double* positions, double* velocities);
    void set_profiling(bool on);
    /// The phases' seconds since the last call (profiling only), then reset.
    EnginePhases take_phases();
    std::string description() const;

private:
    struct Impl;
    std::unique_ptr<Impl> m_impl;
};

/// "" if a CUDA device is usable, else why not.
std::string engine_unavailable_reason();

} // namespace mat::gpu
