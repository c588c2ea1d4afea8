// Lets the selection networks be compiled for the CPU (reference, tests) and inside CUDA kernels
// from the same source.
#pragma once

#if defined(__CUDACC__)
#define IOCT_FILTERS_HD __host__ __device__ __forceinline__
#else
#define IOCT_FILTERS_HD inline
#endif
