// The arithmetic shared by the CPU reference and the CUDA kernels: one definition, compiled for
// host and device, so that both renderers compute the same image.
#pragma once

#include <math.h>

#if defined(__CUDACC__)
#define IOCT_RENDER_HD __host__ __device__ __forceinline__
#else
#define IOCT_RENDER_HD inline
#endif

namespace ioct::gpu::render {

struct Vec3 {
  float x, y, z;
};

IOCT_RENDER_HD Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
IOCT_RENDER_HD Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
IOCT_RENDER_HD Vec3 operator*(float s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
IOCT_RENDER_HD float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
IOCT_RENDER_HD float length(Vec3 a) { return sqrtf(dot(a, a)); }
IOCT_RENDER_HD float clamp01(float v) { return fminf(fmaxf(v, 0.0f), 1.0f); }
IOCT_RENDER_HD float lerp(float a, float b, float t) { return a + (b - a) * t; }

}  // namespace ioct::gpu::render
