// The arithmetic shared by the CPU reference and the CUDA kernels: one definition, compiled for
// host and device, so that both renderers compute the same image.
#pragma once

#include <math.h>

#include "ioct/gpu/cuda/host_device_function.hpp"

namespace ioct::gpu::render {

struct Vec3 {
  float x, y, z;
};

IOCT_HD Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
IOCT_HD Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
IOCT_HD Vec3 operator*(float s, Vec3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
IOCT_HD float dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
IOCT_HD float length(Vec3 a) {
  return sqrtf(dot(a, a));
}
IOCT_HD float clamp01(float v) {
  return fminf(fmaxf(v, 0.0f), 1.0f);
}
IOCT_HD float lerp(float a, float b, float t) {
  return a + (b - a) * t;
}

}  // namespace ioct::gpu::render
