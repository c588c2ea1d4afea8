// Lets the segmentation's per-column arithmetic be compiled for the CPU reference and inside the
// CUDA kernels from the same source, so both compute the same integers and the same floats.
#pragma once

#if defined(__CUDACC__)
#define IOCT_SEG_HD __host__ __device__ __forceinline__
#else
#define IOCT_SEG_HD inline
#endif
