// Functions compiled for both the CPU chain and the CUDA kernels, so both do the very same
// arithmetic: the u8 pixel of a power is computed by one definition.
#pragma once

#include <cstdint>
#include <cstring>

#include "ioct/gpu/cuda/host_device_function.hpp"

namespace ioct::gpu {

// log2 to within 2e-5 (a u8 step is 0.18 dB = 0.06 in log2 at the default range), written so the
// compiler vectorises it; the library log2f is not. x = 2^e * m with m in [1, 2):
// log2(x) = e + log2(m), log2(m) by a polynomial in t = m - 1. Zero and denormals come out very
// negative, which maps to 0.
IOCT_HD float fast_log2(float x) noexcept {
#if defined(__CUDA_ARCH__)
  const std::uint32_t bits = __float_as_uint(x);
  const float mantissa = __uint_as_float((bits & 0x007FFFFFu) | 0x3F800000u);
#else
  std::uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  const std::uint32_t mantissa_bits = (bits & 0x007FFFFFu) | 0x3F800000u;
  float mantissa;
  std::memcpy(&mantissa, &mantissa_bits, sizeof mantissa);
#endif
  const float exponent = static_cast<float>(static_cast<std::int32_t>(bits >> 23) - 127);
  const float t = mantissa - 1.0f;
  // Least-squares fit of log2(1 + t) on [0, 1] by t * (c1 + c2 t + ... + c5 t^4): max error
  // 1.7e-5, i.e. 5e-5 dB.
  const float p =
      t * (1.44187984f +
           t * (-0.708864548f + t * (0.415243263f + t * (-0.193513461f + t * 0.0452668996f))));
  return exponent + p;
}

// Rounds a display level to the nearest u8, clamped. The level is always finite (fast_log2 is),
// so the conversion is defined; clamping as integers keeps the CPU loop free of FP compares,
// which GCC will not turn into vector selects while FP traps are possible.
IOCT_HD std::uint8_t level_to_u8(float level) noexcept {
  const auto rounded = static_cast<std::int32_t>(level + 0.5f);  // toward zero: < 0.5 -> 0
  return static_cast<std::uint8_t>(rounded < 0 ? 0 : (rounded > 255 ? 255 : rounded));
}

// The u8 pixel of an unnormalised FFT power |X|^2: gain and offset come from DbToU8.
IOCT_HD std::uint8_t power_to_u8(float power, float gain, float offset) noexcept {
  return level_to_u8(gain * fast_log2(power) + offset);
}

}  // namespace ioct::gpu
