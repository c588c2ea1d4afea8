// IOCT_HD marks a function compiled for the host and, in CUDA translation units, for the device
// too: the one marker of the arithmetic the CPU references and the CUDA kernels share, so that
// both compute the very same values.
#pragma once

#if defined(__CUDACC__)
#define IOCT_HD __host__ __device__ __forceinline__
#else
#define IOCT_HD inline
#endif
