// The semi-reduced step's kernels and the device memory they work on (docs/gpu.md). Every sum
// has a fixed order (per node over its sorted corners, eight (or four) ways then a fixed
// butterfly; per handle over fixed segments, each reduced in a fixed tree, then in segment order;
// per row of S^-1 in fixed warp reductions, then in warp order): a step's result does not depend
// on the scheduling. The one atomic counter (per handle) decides which block adds the handle's
// segments, not their order.

#include "runtime/gpu/device_engine.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <cuda_runtime.h>

namespace mat::gpu {

namespace {

    void check(cudaError_t status, const char* what)
    {
        if (status != cudaSuccess)
            throw std::runtime_error(
                std::string("cuda: ") + what + ": " + cudaGetErrorString(status));
    }

    template <typename T> T* upload(const std::vector<T>& host, const char* what)
    {
        T* device = nullptr;
        const std::size_t bytes = (host.empty() ? 1 : host.size()) * sizeof(T);
        check(cudaMalloc(&device, bytes), what);
        if (!host.empty())
            check(cudaMemcpy(device, host.data(), host.size() * sizeof(T), cudaMemcpyHostToDevice),
                what);
        return device;
    }

    template <typename T> T* allocate(std::size_t count, const char* what)
    {
        T* device = nullptr;
        check(cudaMalloc(&device, (count == 0 ? 1 : count) * sizeof(T)), what);
        check(cudaMemset(device, 0, (count == 0 ? 1 : count) * sizeof(T)), what);
        return device;
    }

    constexpr int block_size = 128;
    /// Entries of B^T y per segment (one block of block_size threads each), unless the
    /// environment's MAT_CUDA_SEGMENT says otherwise (Engine::Impl::segment_entries).
    constexpr int default_segment_entries = 512;
    constexpr int max_terms = 10;

    int blocks_for(int count)
    {
        return (count + block_size - 1) / block_size;
    }

// Programmatic dependent launch (Hopper, CUDA 12.3 and later, also inside graphs): a kernel of the
// iteration chain may be launched while its predecessor finishes, and waits for it (all its
// writes visible) at its first statement. It hides the launch latency between the chain's short
// kernels, which on a 50k-tet body is a large part of an iteration. Older toolkits launch plainly.
#if defined(CUDART_VERSION) && CUDART_VERSION >= 12030
#define MAT_PDL 1
#else
#define MAT_PDL 0
#endif

    /// The predecessor's writes, before anything reads them (see MAT_PDL). No kernel triggers its
    /// successor early (cudaTriggerProgrammaticLaunchCompletion): the successor launches as this
    /// kernel's blocks exit. Triggering right after this wait made a 50k-tet step slower on an
    /// H100 (docs/gpu.md).
    __device__ inline void wait_for_predecessor()
    {
#if MAT_PDL && defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
        cudaGridDependencySynchronize();
#endif
    }

    /// kernel<<<grid, block_size, 0, stream>>>(args...), allowed to overlap its predecessor's
    /// end where the toolkit has programmatic dependent launch.
    template <typename... Params, typename... Args>
    void launch(void (*kernel)(Params...), int grid, cudaStream_t stream, Args... args)
    {
        if (grid <= 0)
            return;
#if MAT_PDL
        cudaLaunchConfig_t config {};
        config.gridDim = dim3(static_cast<unsigned>(grid));
        config.blockDim = dim3(block_size);
        config.stream = stream;
        cudaLaunchAttribute attribute {};
        attribute.id = cudaLaunchAttributeProgrammaticStreamSerialization;
        attribute.val.programmaticStreamSerializationAllowed = 1;
        config.attrs = &attribute;
        config.numAttrs = 1;
        check(cudaLaunchKernelEx(&config, kernel, static_cast<Params>(args)...), "kernel launch");
#else
        kernel<<<grid, block_size, 0, stream>>>(static_cast<Params>(args)...);
#endif
    }

    // ---- kernels ----------------------------------------------------------------------------

    struct StepConstants {
        double h;
        double gravity[3];
        double velocity_scale; ///< (1 - damping) / h
        double pin_weight;
    };

    /// s = x_n + h v_n + h^2 g, x = s, base = M s / h^2 - A X.
    __global__ void begin_kernel(int n, StepConstants k, const double* __restrict__ xn,
        const double* __restrict__ v, const double* __restrict__ mass_h2,
        const double* __restrict__ rest_system, double* __restrict__ x, double* __restrict__ base)
    {
        const int i = blockIdx.x * blockDim.x + threadIdx.x;
        if (i >= n)
            return;
        for (int c = 0; c < 3; ++c) {
            const double s = xn[3 * i + c] + k.h * v[3 * i + c] + k.h * k.h * k.gravity[c];
            x[3 * i + c] = s;
            base[3 * i + c] = mass_h2[i] * s - rest_system[3 * i + c];
        }
    }

    /// base += w_p p at the pinned nodes (distinct).
    __global__ void pin_kernel(int count, double weight, const int* __restrict__ nodes,
        const double* __restrict__ targets, double* __restrict__ base)
    {
        const int p = blockIdx.x * blockDim.x + threadIdx.x;
        if (p >= count)
            return;
        for (int c = 0; c < 3; ++c)
            base[3 * nodes[p] + c] += weight * targets[3 * p + c];
    }

    /// One tet per thread: F, its weighted projection, the corners' shares. `MinBlocks`: blocks
    /// per SM it is compiled for, a register cap (3: uncapped, 154 registers with CUDA 13; 4:
    /// 128 registers and a few spills; 5: 102 and more). The engine picks one (Impl::local_blocks).
    template <int MinBlocks>
    __global__ void __launch_bounds__(block_size, MinBlocks)
        local_kernel(int tets, ProjectionWeights weights, const int4* __restrict__ tet_nodes,
            const double* __restrict__ dm_inverse, const double* __restrict__ volumes,
            const double* __restrict__ x, float4* __restrict__ warm, double* __restrict__ shares)
    {
        wait_for_predecessor();
        const int e = blockIdx.x * blockDim.x + threadIdx.x;
        if (e >= tets)
            return;
        const int4 corners = tet_nodes[e];
        const int ids[4] = { corners.x, corners.y, corners.z, corners.w };
        double p[4][3];
        for (int c = 0; c < 4; ++c)
            for (int d = 0; d < 3; ++d)
                p[c][d] = x[3 * ids[c] + d];
        double dm[9];
        for (int j = 0; j < 9; ++j)
            dm[j] = dm_inverse[static_cast<long long>(j) * tets + e];
        double f[3][3];
        deformation_gradient(p, dm, f);
        const float4 w4 = warm[e];
        float quat[4] = { w4.x, w4.y, w4.z, w4.w };
        double target[3][3];
        weighted_projection(f, weights, quat, target);
        warm[e] = make_float4(quat[0], quat[1], quat[2], quat[3]);
        double share[4][3];
        corner_shares(dm, volumes[e], target, share);
        double* out = shares + 12 * static_cast<long long>(e);
        for (int c = 0; c < 4; ++c)
            for (int d = 0; d < 3; ++d)
                out[3 * c + d] = share[c][d];
    }

    /// Threads per node in the per-node kernels (`Group`: 4 or 8, Engine::Impl::node_group):
    /// their sums split that many ways, then added in a fixed butterfly (commutative at each
    /// level: every lane gets the same bits).
    template <int Group> __device__ inline double group_sum(double value)
    {
#pragma unroll
        for (int lane_mask = 1; lane_mask < Group; lane_mask <<= 1)
            value += __shfl_xor_sync(0xffffffffu, value, lane_mask);
        return value;
    }

    /// `Group` threads per node: y = base + its corners' shares (corner j to thread j mod Group).
    template <int Group>
    __global__ void gather_kernel(int n, const int* __restrict__ offsets,
        const int* __restrict__ corners, const double* __restrict__ shares,
        const double* __restrict__ base, double* __restrict__ y)
    {
        wait_for_predecessor();
        const int thread = blockIdx.x * blockDim.x + threadIdx.x;
        const int i = thread / Group, sub = thread % Group;
        double s0 = 0.0, s1 = 0.0, s2 = 0.0;
        if (i < n)
            for (int j = offsets[i] + sub; j < offsets[i + 1]; j += Group) {
                const double* share = shares + 3 * static_cast<long long>(corners[j]);
                s0 += share[0];
                s1 += share[1];
                s2 += share[2];
            }
        s0 = group_sum<Group>(s0);
        s1 = group_sum<Group>(s1);
        s2 = group_sum<Group>(s2);
        if (i < n && sub < 3)
            y[3 * i + sub] = base[3 * i + sub] + (sub == 0 ? s0 : sub == 1 ? s1 : s2);
    }

    struct Segments {
        const int* handle; ///< per segment
        const int* begin; ///< per segment: first entry
        const int* end;
        int count;
    };

    __device__ inline double warp_sum(double value)
    {
        for (int offset = 16; offset > 0; offset >>= 1)
            value += __shfl_down_sync(0xffffffffu, value, offset);
        return value;
    }

    /// The data of transpose_kernel.
    struct TransposeData {
        Segments segments; ///< all of them, linear handles' first
        int linear_segments;
        const double* centers;
        const double* scales;
        const int* entry_nodes;
        const double* entry_weights;
        const double* rest;
        const double* y;
        double* partials; ///< per segment, max_terms * 3
        const int* partial_ranges;
        const int* offsets;
        unsigned int* tickets;
        double* reduced;
    };

    /// Segment `seg` of one handle's entries: sum_e w_e p_t(y_e) y_{node e}, for the handle's
    /// `Terms` monomials and three coordinates, into the segment's partial (`warps`: the block's
    /// shared scratch). The last block of a handle to finish (counted in `tickets`, which it
    /// resets) adds the handle's partials in segment order into its rows of `reduced`: which
    /// block that is varies, the sum does not.
    template <int Terms>
    __device__ void transpose_segment(
        const TransposeData& d, int seg, double (*warps)[max_terms * 3], bool& last)
    {
        const double* __restrict__ rest = d.rest;
        const double* __restrict__ y = d.y;
        const int j = d.segments.handle[seg];
        const double cx = d.centers[3 * j], cy = d.centers[3 * j + 1], cz = d.centers[3 * j + 2];
        const double inverse_scale = d.scales[j];
        double acc[Terms * 3];
        for (int t = 0; t < Terms * 3; ++t)
            acc[t] = 0.0;
        const int end = d.segments.end[seg];
        for (int e = d.segments.begin[seg] + threadIdx.x; e < end; e += blockDim.x) {
            const int i = d.entry_nodes[e];
            const double w = d.entry_weights[e];
            double p[max_terms];
            handle_monomials((rest[3 * i] - cx) * inverse_scale,
                (rest[3 * i + 1] - cy) * inverse_scale, (rest[3 * i + 2] - cz) * inverse_scale, p);
            const double y0 = y[3 * i], y1 = y[3 * i + 1], y2 = y[3 * i + 2];
#pragma unroll
            for (int t = 0; t < Terms; ++t) {
                const double wp = w * p[t];
                acc[3 * t] += wp * y0;
                acc[3 * t + 1] += wp * y1;
                acc[3 * t + 2] += wp * y2;
            }
        }
        const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
#pragma unroll
        for (int t = 0; t < Terms * 3; ++t) {
            const double sum = warp_sum(acc[t]);
            if (lane == 0)
                warps[warp][t] = sum;
        }
        __syncthreads();
        if (threadIdx.x < Terms * 3) {
            double sum = 0.0;
            for (int w = 0; w < block_size / 32; ++w)
                sum += warps[w][threadIdx.x];
            d.partials[static_cast<long long>(seg) * (max_terms * 3) + threadIdx.x] = sum;
        }
        __threadfence();
        __syncthreads();
        const int first = d.partial_ranges[2 * j], count = d.partial_ranges[2 * j + 1] - first;
        if (threadIdx.x == 0)
            last = atomicAdd(&d.tickets[j], 1u) == static_cast<unsigned int>(count - 1);
        __syncthreads();
        if (!last)
            return;
        if (threadIdx.x < Terms * 3) {
            double sum = 0.0;
            for (int p = first; p < first + count; ++p) // other blocks' writes: past L1
                sum += __ldcg(
                    d.partials + static_cast<long long>(p) * (max_terms * 3) + threadIdx.x);
            d.reduced[3 * d.offsets[j] + threadIdx.x] = sum;
        }
        if (threadIdx.x == 0)
            d.tickets[j] = 0;
    }

    /// One block per segment: linear handles' segments (4 monomials), then quadratic ones' (10).
    __global__ void transpose_kernel(TransposeData d)
    {
        wait_for_predecessor();
        const int seg = static_cast<int>(blockIdx.x);
        if (seg >= d.segments.count)
            return;
        __shared__ double warps[block_size / 32][max_terms * 3];
        __shared__ bool last;
        if (seg < d.linear_segments)
            transpose_segment<4>(d, seg, warps, last);
        else
            transpose_segment<10>(d, seg, warps, last);
    }

    /// `Warps` warps per row of S^-1 (1, or block_size / 32: a block per row): q_row = S^-1_row
    /// (B^T y), three right-hand sides. The warps' sums are added in warp order.
    template <int Warps>
    __global__ void solve_kernel(int k, const double* __restrict__ inverse,
        const double* __restrict__ reduced, double* __restrict__ q)
    {
        wait_for_predecessor();
        constexpr int threads = 32 * Warps;
        const int row = (blockIdx.x * blockDim.x + threadIdx.x) / threads;
        const int lane = threadIdx.x % threads;
        if (row >= k)
            return;
        const double* a = inverse + static_cast<long long>(row) * k;
        double s0 = 0.0, s1 = 0.0, s2 = 0.0;
#pragma unroll 4
        for (int c = lane; c < k; c += threads) {
            const double value = a[c];
            s0 += value * reduced[3 * c];
            s1 += value * reduced[3 * c + 1];
            s2 += value * reduced[3 * c + 2];
        }
        s0 = warp_sum(s0);
        s1 = warp_sum(s1);
        s2 = warp_sum(s2);
        if constexpr (Warps == 1) {
            if (lane == 0) {
                q[3 * row] = s0;
                q[3 * row + 1] = s1;
                q[3 * row + 2] = s2;
            }
        } else {
            __shared__ double warps[Warps][3];
            if (lane % 32 == 0) {
                warps[lane / 32][0] = s0;
                warps[lane / 32][1] = s1;
                warps[lane / 32][2] = s2;
            }
            __syncthreads();
            if (lane < 3) {
                double sum = 0.0;
                for (int w = 0; w < Warps; ++w)
                    sum += warps[w][lane];
                q[3 * row + lane] = sum;
            }
        }
    }

    /// `Group` threads per node: x = X + sum over its handles of w p(y) q (entry e to thread
    /// e mod Group).
    template <int Group>
    __global__ void reconstruct_kernel(int n, const double* __restrict__ centers,
        const double* __restrict__ scales, const int* __restrict__ handle_offsets,
        const int* __restrict__ handle_terms, const int* __restrict__ entry_offsets,
        const int* __restrict__ entry_handles, const double* __restrict__ entry_weights,
        const double* __restrict__ rest, const double* __restrict__ q, double* __restrict__ x)
    {
        wait_for_predecessor();
        const int thread = blockIdx.x * blockDim.x + threadIdx.x;
        const int i = thread / Group, sub = thread % Group;
        double x0 = 0.0, x1 = 0.0, x2 = 0.0;
        if (i < n) {
            const double rx = rest[3 * i], ry = rest[3 * i + 1], rz = rest[3 * i + 2];
            for (int e = entry_offsets[i] + sub; e < entry_offsets[i + 1]; e += Group) {
                const int j = entry_handles[e];
                const double w = entry_weights[e];
                const double inverse_scale = scales[j];
                double p[max_terms];
                handle_monomials((rx - centers[3 * j]) * inverse_scale,
                    (ry - centers[3 * j + 1]) * inverse_scale,
                    (rz - centers[3 * j + 2]) * inverse_scale, p);
                const double* qj = q + 3 * handle_offsets[j];
                const int terms = handle_terms[j];
#pragma unroll
                for (int t = 0; t < max_terms; ++t) // unrolled: p stays in registers
                    if (t < terms) {
                        const double wp = w * p[t];
                        x0 += wp * qj[3 * t];
                        x1 += wp * qj[3 * t + 1];
                        x2 += wp * qj[3 * t + 2];
                    }
            }
        }
        x0 = group_sum<Group>(x0);
        x1 = group_sum<Group>(x1);
        x2 = group_sum<Group>(x2);
        if (i < n && sub < 3)
            x[3 * i + sub] = rest[3 * i + sub] + (sub == 0 ? x0 : sub == 1 ? x1 : x2);
    }

    /// The smallest of the block's threads' `value`s, for every thread (`least`: block_size
    /// doubles of shared memory, free again on return).
    __device__ inline double block_min(double value, double* least)
    {
        least[threadIdx.x] = value;
        __syncthreads();
        for (int half = block_size / 2; half > 0; half >>= 1) {
            if (threadIdx.x < half)
                least[threadIdx.x] = fmin(least[threadIdx.x], least[threadIdx.x + half]);
            __syncthreads();
        }
        const double smallest = least[0];
        __syncthreads();
        return smallest;
    }

    /// Per block and plane, the smallest n . x - n . p over its nodes at x_n and at s (planes: 4
    /// doubles each, the unit normal and n . p). The minimum does not depend on the order.
    __global__ void plane_kernel(int n, int num_planes, const double* __restrict__ planes,
        const double* __restrict__ xn, const double* __restrict__ s,
        double* __restrict__ block_minima)
    {
        __shared__ double least[block_size];
        for (int p = 0; p < num_planes; ++p) {
            const double* plane = planes + 4 * p;
            double m = 1e300;
            for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < n;
                 i += gridDim.x * blockDim.x) {
                const double a = plane[0] * xn[3 * i] + plane[1] * xn[3 * i + 1]
                    + plane[2] * xn[3 * i + 2] - plane[3];
                const double b = plane[0] * s[3 * i] + plane[1] * s[3 * i + 1]
                    + plane[2] * s[3 * i + 2] - plane[3];
                m = fmin(m, fmin(a, b));
            }
            m = block_min(m, least);
            if (threadIdx.x == 0)
                block_minima[static_cast<long long>(p) * gridDim.x + blockIdx.x] = m;
        }
    }

    /// One block: each plane's minimum over the blocks' minima.
    __global__ void plane_reduce_kernel(int blocks, int num_planes,
        const double* __restrict__ block_minima, double* __restrict__ minima)
    {
        __shared__ double least[block_size];
        for (int p = 0; p < num_planes; ++p) {
            double m = 1e300;
            for (int b = threadIdx.x; b < blocks; b += blockDim.x)
                m = fmin(m, block_minima[static_cast<long long>(p) * blocks + b]);
            m = block_min(m, least);
            if (threadIdx.x == 0)
                minima[p] = m;
        }
    }

    /// v = (1 - damping) (x - x_n) / h, then x_n = x (the next step's start).
    __global__ void end_kernel(int count, double scale, const double* __restrict__ x,
        double* __restrict__ xn, double* __restrict__ v)
    {
        const int i = blockIdx.x * blockDim.x + threadIdx.x;
        if (i < count) {
            const double now = x[i];
            v[i] = scale * (now - xn[i]);
            xn[i] = now;
        }
    }

} // namespace

struct Engine::Impl {
    int n = 0, tets = 0, k = 0, m = 0, pins = 0, iterations = 1;
    /// The local kernel's register cap (local_kernel's MinBlocks): 4, or the environment's
    /// MAT_CUDA_LOCAL_BLOCKS (3, 4 or 5), for tuning on a new GPU.
    int local_blocks = 4;
    /// More launch settings, which the environment may change for tuning on a new GPU
    /// (gpu_bench's variants): entries per B^T y segment (MAT_CUDA_SEGMENT), threads per node in
    /// the gather and the reconstruction (MAT_CUDA_NODE_GROUP: 4 or 8), warps per row of the
    /// solve (MAT_CUDA_SOLVE_WARPS: 1 or 4).
    int segment_entries = default_segment_entries;
    int node_group = 8;
    int solve_warps = block_size / 32;
    StepConstants constants {};
    ProjectionWeights weights;
    cudaStream_t stream = nullptr;
    // Model.
    int4* tet_nodes = nullptr;
    double* dm_inverse = nullptr; ///< 9 T, component-major (j T + e)
    double* volumes = nullptr;
    int* incident_offsets = nullptr;
    int* incident_corners = nullptr;
    double* rest = nullptr;
    double* mass_h2 = nullptr;
    double* rest_system = nullptr;
    int* pin_nodes = nullptr;
    double* centers = nullptr;
    double* scales = nullptr; ///< m: 1 / s_j
    int* handle_offsets = nullptr;
    int* handle_terms = nullptr;
    int* node_entry_offsets = nullptr;
    int* node_entry_handles = nullptr;
    double* node_entry_weights = nullptr;
    int* handle_entry_nodes = nullptr;
    double* handle_entry_weights = nullptr;
    double* inverse = nullptr;
    // Segments of B^T y: linear handles' first, then quadratic ones'.
    int* segment_handle = nullptr;
    int* segment_begin = nullptr;
    int* segment_end = nullptr;
    int linear_segments = 0, quadratic_segments = 0;
    int* partial_ranges = nullptr; ///< 2 m: handle j's partials
    unsigned int* tickets = nullptr; ///< m: blocks of handle j done (0 between launches)
    // State and workspace.
    float4* warm = nullptr;
    double* shares = nullptr;
    double* x = nullptr;
    double* xn = nullptr;
    double* v = nullptr;
    double* base = nullptr;
    double* y = nullptr;
    double* partials = nullptr;
    double* reduced = nullptr;
    double* q = nullptr;
    double* pin_targets = nullptr;
    // Ground planes: each one's nearest node at x_n or s, per block then in all.
    int num_planes = 0;
    int plane_blocks = 0;
    double* planes = nullptr;
    double* plane_block_minima = nullptr;
    double* plane_minima = nullptr;
    double* host_plane_minima = nullptr; ///< pinned
    std::vector<double> minima;
    // Pinned host staging.
    double* host_state = nullptr; ///< 6 n: x then v
    double* host_q = nullptr; ///< 3 k
    // Graph of every iteration.
    cudaGraphExec_t graph = nullptr;
    // Profiling.
    bool profiling = false;
    cudaEvent_t marks[2] = { nullptr, nullptr };
    EnginePhases phases;

    void mark_begin()
    {
        if (profiling)
            check(cudaEventRecord(marks[0], stream), "event");
    }
    void mark_end(double& phase)
    {
        if (!profiling)
            return;
        check(cudaEventRecord(marks[1], stream), "event");
        check(cudaEventSynchronize(marks[1]), "event");
        float ms = 0.0f;
        check(cudaEventElapsedTime(&ms, marks[0], marks[1]), "event");
        phase += 1e-3 * ms;
    }

    void launch_local()
    {
        const int grid = blocks_for(tets);
        const auto kernel = local_blocks == 3 ? local_kernel<3>
            : local_blocks == 5               ? local_kernel<5>
                                              : local_kernel<4>;
        launch(
            kernel, grid, stream, tets, weights, tet_nodes, dm_inverse, volumes, x, warm, shares);
    }
    void launch_gather()
    {
        launch(node_group == 8 ? gather_kernel<8> : gather_kernel<4>, blocks_for(n * node_group),
            stream, n, incident_offsets, incident_corners, shares, base, y);
    }
    void launch_transpose()
    {
        const int segments = linear_segments + quadratic_segments;
        const TransposeData data { Segments {
                                       segment_handle, segment_begin, segment_end, segments },
            linear_segments, centers, scales, handle_entry_nodes, handle_entry_weights, rest, y,
            partials, partial_ranges, handle_offsets, tickets, reduced };
        launch(transpose_kernel, segments, stream, data);
    }
    void launch_solve()
    {
        if (solve_warps == 1)
            launch(solve_kernel<1>, (k * 32 + block_size - 1) / block_size, stream, k, inverse,
                reduced, q);
        else
            launch(solve_kernel<block_size / 32>, k, stream, k, inverse, reduced, q);
    }
    void launch_reconstruct()
    {
        launch(node_group == 8 ? reconstruct_kernel<8> : reconstruct_kernel<4>,
            blocks_for(n * node_group), stream, n, centers, scales, handle_offsets, handle_terms,
            node_entry_offsets, node_entry_handles, node_entry_weights, rest, q, x);
    }
    void iterate()
    {
        mark_begin();
        launch_local();
        mark_end(phases.local);
        mark_begin();
        launch_gather();
        mark_end(phases.gather);
        mark_begin();
        launch_transpose();
        mark_end(phases.rhs);
        mark_begin();
        launch_solve();
        mark_end(phases.solve);
        check(cudaGetLastError(), "iteration kernels");
    }
    void reconstruct()
    {
        mark_begin();
        launch_reconstruct();
        mark_end(phases.reconstruct);
        check(cudaGetLastError(), "reconstruction kernel");
    }

    void build_segments(const EngineModel& model);
    void build_graph();
    void release();
};

void Engine::Impl::build_segments(const EngineModel& model)
{
    // Each handle's entries in segments of at most segment_entries, linear handles first.
    std::vector<int> handle, begin, end;
    for (int pass = 0; pass < 2; ++pass) {
        for (int j = 0; j < m; ++j) {
            if ((model.handle_terms[j] == max_terms) != (pass == 1))
                continue;
            const int first = model.handle_entry_offsets[j];
            const int last = model.handle_entry_offsets[j + 1];
            for (int b = first; b < last; b += segment_entries) {
                handle.push_back(j);
                begin.push_back(b);
                end.push_back(std::min(b + segment_entries, last));
            }
            if (pass == 0)
                linear_segments += (last - first + segment_entries - 1) / segment_entries;
            else
                quadratic_segments += (last - first + segment_entries - 1) / segment_entries;
        }
    }
    // Partials are stored in segment order, each handle's contiguous: its range, per handle.
    std::vector<int> ranges(2 * static_cast<std::size_t>(m), 0);
    for (int seg = static_cast<int>(handle.size()) - 1; seg >= 0; --seg) {
        const int j = handle[seg];
        if (ranges[2 * j + 1] == 0)
            ranges[2 * j + 1] = seg + 1;
        ranges[2 * j] = seg;
    }
    segment_handle = upload(handle, "segments");
    segment_begin = upload(begin, "segments");
    segment_end = upload(end, "segments");
    partial_ranges = upload(ranges, "segments");
    partials = allocate<double>(handle.size() * max_terms * 3, "partials");
    tickets = allocate<unsigned int>(static_cast<std::size_t>(m), "partials");
}

void Engine::Impl::build_graph()
{
    cudaGraph_t captured = nullptr;
    check(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal), "graph capture");
    for (int it = 0; it < iterations; ++it) {
        launch_local();
        launch_gather();
        launch_transpose();
        launch_solve();
        launch_reconstruct();
    }
    check(cudaStreamEndCapture(stream, &captured), "graph capture");
    check(cudaGraphInstantiateWithFlags(&graph, captured, 0), "graph instantiate");
    check(cudaGraphDestroy(captured), "graph");
}

void Engine::Impl::release()
{
    if (graph)
        cudaGraphExecDestroy(graph);
    for (cudaEvent_t& e : marks)
        if (e)
            cudaEventDestroy(e);
    void* buffers[] = { tet_nodes, dm_inverse, volumes, incident_offsets, incident_corners, rest,
        mass_h2, rest_system, pin_nodes, centers, scales, handle_offsets, handle_terms,
        node_entry_offsets, node_entry_handles, node_entry_weights, handle_entry_nodes,
        handle_entry_weights, inverse, segment_handle, segment_begin, segment_end, partial_ranges,
        warm, shares, x, xn, v, base, y, partials, reduced, q, pin_targets };
    for (void* b : buffers)
        if (b)
            cudaFree(b);
    if (host_state)
        cudaFreeHost(host_state);
    if (host_q)
        cudaFreeHost(host_q);
    if (host_plane_minima)
        cudaFreeHost(host_plane_minima);
    if (stream)
        cudaStreamDestroy(stream);
}

Engine::Engine(const EngineModel& model)
    : m_impl(std::make_unique<Impl>())
{
    Impl& d = *m_impl;
    try {
        d.n = model.nodes;
        d.tets = model.tets;
        d.k = model.columns;
        d.m = model.handles;
        d.pins = static_cast<int>(model.pin_nodes.size());
        d.iterations = model.iterations;
        if (const char* blocks = std::getenv("MAT_CUDA_LOCAL_BLOCKS"))
            d.local_blocks = std::atoi(blocks);
        if (const char* segment = std::getenv("MAT_CUDA_SEGMENT"))
            d.segment_entries = std::max(32, std::atoi(segment));
        if (const char* group = std::getenv("MAT_CUDA_NODE_GROUP"))
            d.node_group = std::atoi(group) == 8 ? 8 : 4;
        if (const char* warps = std::getenv("MAT_CUDA_SOLVE_WARPS"))
            d.solve_warps = std::atoi(warps) == 1 ? 1 : block_size / 32;
        d.weights = model.weights;
        d.constants.h = model.time_step;
        for (int c = 0; c < 3; ++c)
            d.constants.gravity[c] = model.gravity[c];
        d.constants.velocity_scale = (1.0 - model.damping) / model.time_step;
        d.constants.pin_weight = model.pin_weight;
        check(cudaStreamCreateWithFlags(&d.stream, cudaStreamNonBlocking), "stream");
        for (cudaEvent_t& e : d.marks)
            check(cudaEventCreate(&e), "event");
        std::vector<int4> nodes(static_cast<std::size_t>(d.tets));
        for (int e = 0; e < d.tets; ++e)
            nodes[e] = make_int4(model.tet_nodes[4 * e], model.tet_nodes[4 * e + 1],
                model.tet_nodes[4 * e + 2], model.tet_nodes[4 * e + 3]);
        d.tet_nodes = upload(nodes, "tets");
        std::vector<double> dm(9 * static_cast<std::size_t>(d.tets));
        for (int e = 0; e < d.tets; ++e)
            for (int j = 0; j < 9; ++j)
                dm[static_cast<std::size_t>(j) * d.tets + e] = model.dm_inverse[9 * e + j];
        d.dm_inverse = upload(dm, "Dm^-1");
        d.volumes = upload(model.volumes, "volumes");
        d.incident_offsets = upload(model.incident_offsets, "incidence");
        d.incident_corners = upload(model.incident_corners, "incidence");
        d.rest = upload(model.rest, "rest positions");
        d.mass_h2 = upload(model.mass_over_h2, "masses");
        d.rest_system = upload(model.rest_system, "A X");
        d.pin_nodes = upload(model.pin_nodes, "pins");
        d.centers = upload(model.handle_centers, "handles");
        d.scales = upload(model.handle_inverse_scales, "handles");
        d.handle_offsets = upload(model.handle_offsets, "handles");
        d.handle_terms = upload(model.handle_terms, "handles");
        d.node_entry_offsets = upload(model.node_entry_offsets, "basis");
        d.node_entry_handles = upload(model.node_entry_handles, "basis");
        d.node_entry_weights = upload(model.node_entry_weights, "basis");
        d.handle_entry_nodes = upload(model.handle_entry_nodes, "basis");
        d.handle_entry_weights = upload(model.handle_entry_weights, "basis");
        d.inverse = upload(model.inverse, "S^-1");
        d.build_segments(model);
        std::vector<float4> identity(
            static_cast<std::size_t>(d.tets), make_float4(1.0f, 0.0f, 0.0f, 0.0f));
        d.warm = upload(identity, "warm start");
        d.shares = allocate<double>(12 * static_cast<std::size_t>(d.tets), "shares");
        const std::size_t n3 = 3 * static_cast<std::size_t>(d.n);
        d.x = allocate<double>(n3, "positions");
        d.xn = allocate<double>(n3, "positions");
        d.v = allocate<double>(n3, "velocities");
        d.base = allocate<double>(n3, "right-hand side");
        d.y = allocate<double>(n3, "right-hand side");
        d.reduced = allocate<double>(3 * static_cast<std::size_t>(d.k), "reduced right-hand side");
        d.q = allocate<double>(3 * static_cast<std::size_t>(d.k), "q");
        d.pin_targets = allocate<double>(3 * static_cast<std::size_t>(d.pins), "pin targets");
        check(cudaMallocHost(&d.host_state, 2 * n3 * sizeof(double)), "host staging");
        check(cudaMallocHost(&d.host_q, 3 * static_cast<std::size_t>(d.k) * sizeof(double) + 8),
            "host staging");
        d.num_planes = static_cast<int>(model.planes.size() / 4);
        d.plane_blocks = std::min(blocks_for(d.n), 256);
        d.planes = upload(model.planes, "planes");
        d.plane_block_minima = allocate<double>(
            static_cast<std::size_t>(d.plane_blocks) * d.num_planes, "plane distances");
        d.plane_minima = allocate<double>(d.num_planes, "plane distances");
        check(cudaMallocHost(&d.host_plane_minima, (d.num_planes + 1) * sizeof(double)),
            "host staging");
        d.build_graph();
        check(cudaStreamSynchronize(d.stream), "upload");
    } catch (...) {
        d.release();
        throw;
    }
}

Engine::~Engine()
{
    m_impl->release();
}

void Engine::upload_state(const double* positions, const double* velocities)
{
    Impl& d = *m_impl;
    const std::size_t n3 = 3 * static_cast<std::size_t>(d.n);
    // The staging buffer's last use (a download) has been waited for.
    std::memcpy(d.host_state, positions, n3 * sizeof(double));
    std::memcpy(d.host_state + n3, velocities, n3 * sizeof(double));
    check(
        cudaMemcpyAsync(d.xn, d.host_state, n3 * sizeof(double), cudaMemcpyHostToDevice, d.stream),
        "state upload");
    check(cudaMemcpyAsync(
              d.v, d.host_state + n3, n3 * sizeof(double), cudaMemcpyHostToDevice, d.stream),
        "state upload");
    check(cudaStreamSynchronize(d.stream), "state upload");
}

void Engine::begin_step(const double* pins)
{
    Impl& d = *m_impl;
    if (d.pins > 0)
        check(cudaMemcpyAsync(d.pin_targets, pins, 3 * static_cast<std::size_t>(d.pins) * 8,
                  cudaMemcpyHostToDevice, d.stream),
            "pin upload");
    d.mark_begin();
    begin_kernel<<<blocks_for(d.n), block_size, 0, d.stream>>>(
        d.n, d.constants, d.xn, d.v, d.mass_h2, d.rest_system, d.x, d.base);
    if (d.pins > 0)
        pin_kernel<<<blocks_for(d.pins), block_size, 0, d.stream>>>(
            d.pins, d.constants.pin_weight, d.pin_nodes, d.pin_targets, d.base);
    if (d.num_planes > 0) {
        plane_kernel<<<d.plane_blocks, block_size, 0, d.stream>>>(
            d.n, d.num_planes, d.planes, d.xn, d.x, d.plane_block_minima);
        plane_reduce_kernel<<<1, block_size, 0, d.stream>>>(
            d.plane_blocks, d.num_planes, d.plane_block_minima, d.plane_minima);
        check(cudaMemcpyAsync(d.host_plane_minima, d.plane_minima,
                  static_cast<std::size_t>(d.num_planes) * sizeof(double), cudaMemcpyDeviceToHost,
                  d.stream),
            "plane distances");
    }
    d.mark_end(d.phases.begin_end);
    check(cudaGetLastError(), "step start kernels");
    if (d.num_planes > 0) {
        check(cudaStreamSynchronize(d.stream), "plane distances");
        d.minima.assign(d.host_plane_minima, d.host_plane_minima + d.num_planes);
    }
}

const std::vector<double>& Engine::plane_minima() const
{
    return m_impl->minima;
}

void Engine::iterate()
{
    m_impl->iterate();
}

void Engine::iterate_all()
{
    Impl& d = *m_impl;
    if (d.profiling) {
        for (int it = 0; it < d.iterations; ++it) {
            d.iterate();
            d.reconstruct();
        }
        return;
    }
    check(cudaGraphLaunch(d.graph, d.stream), "graph launch");
}

void Engine::download_q(double* q)
{
    Impl& d = *m_impl;
    const std::size_t bytes = 3 * static_cast<std::size_t>(d.k) * sizeof(double);
    check(cudaMemcpyAsync(d.host_q, d.q, bytes, cudaMemcpyDeviceToHost, d.stream), "q download");
    check(cudaStreamSynchronize(d.stream), "q download");
    std::memcpy(q, d.host_q, bytes);
}

void Engine::upload_q(const double* q)
{
    Impl& d = *m_impl;
    const std::size_t bytes = 3 * static_cast<std::size_t>(d.k) * sizeof(double);
    std::memcpy(d.host_q, q, bytes);
    check(cudaMemcpyAsync(d.q, d.host_q, bytes, cudaMemcpyHostToDevice, d.stream), "q upload");
    check(cudaStreamSynchronize(d.stream), "q upload");
}

void Engine::reconstruct()
{
    m_impl->reconstruct();
}

void Engine::download_positions(double* x)
{
    Impl& d = *m_impl;
    const std::size_t bytes = 3 * static_cast<std::size_t>(d.n) * sizeof(double);
    check(cudaMemcpyAsync(d.host_state, d.x, bytes, cudaMemcpyDeviceToHost, d.stream),
        "positions download");
    check(cudaStreamSynchronize(d.stream), "positions download");
    std::memcpy(x, d.host_state, bytes);
}

void Engine::end_step()
{
    Impl& d = *m_impl;
    const std::size_t n3 = 3 * static_cast<std::size_t>(d.n);
    d.mark_begin();
    end_kernel<<<blocks_for(static_cast<int>(n3)), block_size, 0, d.stream>>>(
        static_cast<int>(n3), d.constants.velocity_scale, d.x, d.xn, d.v);
    d.mark_end(d.phases.begin_end);
    check(cudaGetLastError(), "step end kernel");
}

void Engine::download_state(double* positions, double* velocities)
{
    Impl& d = *m_impl;
    const std::size_t n3 = 3 * static_cast<std::size_t>(d.n);
    check(
        cudaMemcpyAsync(d.host_state, d.xn, n3 * sizeof(double), cudaMemcpyDeviceToHost, d.stream),
        "state download");
    check(cudaMemcpyAsync(
              d.host_state + n3, d.v, n3 * sizeof(double), cudaMemcpyDeviceToHost, d.stream),
        "state download");
    check(cudaStreamSynchronize(d.stream), "state download");
    std::memcpy(positions, d.host_state, n3 * sizeof(double));
    std::memcpy(velocities, d.host_state + n3, n3 * sizeof(double));
}

void Engine::set_profiling(bool on)
{
    m_impl->profiling = on;
}

EnginePhases Engine::take_phases()
{
    EnginePhases out = m_impl->phases;
    m_impl->phases = EnginePhases {};
    return out;
}

std::string Engine::description() const
{
    int device = 0;
    cudaDeviceProp props {};
    if (cudaGetDevice(&device) != cudaSuccess
        || cudaGetDeviceProperties(&props, device) != cudaSuccess)
        return "cuda device";
    char text[256];
    std::snprintf(text, sizeof(text), "%s, %.0f GiB, compute capability %d.%d", props.name,
        static_cast<double>(props.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0), props.major,
        props.minor);
    return text;
}

std::string engine_unavailable_reason()
{
    int count = 0;
    const cudaError_t status = cudaGetDeviceCount(&count);
    if (status != cudaSuccess)
        return std::string("no usable CUDA device (") + cudaGetErrorString(status) + ")";
    if (count == 0)
        return "no CUDA device found";
    return "";
}

} // namespace mat::gpu
