#pragma once
// MAT_HD marks a function that compiles for the CPU and, under nvcc, for a CUDA GPU too (the GPU
// step's arithmetic, runtime/gpu/device_math.hpp, and the helpers it shares with the CPU path).

#if defined(__CUDACC__)
#define MAT_HD __host__ __device__ inline
#else
#define MAT_HD inline
#endif
