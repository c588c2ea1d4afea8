// Frozen speckle: the random parts of the tissue under the beam are hashed from where the beam
// is, so still tissue shows the same speckle every time the beam returns to it (volume after
// volume, forward and reverse lines alike) while only the detector noise changes.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/random.hpp"

namespace ioct::sim {

// The key of the tissue cell under `beam`: cells of `grain_um` on the sample (finer than the
// beam's spot, so neighbouring A-scans of a raster see independent speckle).
inline std::uint64_t lateral_key(std::uint64_t seed_key, hal::BeamPosition beam,
                                 double field_half_width_mm, double grain_um) noexcept {
  const double cell = grain_um * 1e-3 / field_half_width_mm;  // scan units
  const auto cx = static_cast<std::int64_t>(std::lround(beam.x / cell));
  const auto cy = static_cast<std::int64_t>(std::lround(beam.y / cell));
  return splitmix64(seed_key ^ splitmix64(static_cast<std::uint64_t>(cx) * 0x9E3779B97F4A7C15ull ^
                                          static_cast<std::uint64_t>(cy)));
}

// Amplitude of a thin line's reflection: (1 - c) + c R, R Rayleigh with mean 1, drawn from `key`.
inline float speckle_amplitude(std::uint64_t key, float contrast) noexcept {
  if (contrast <= 0.0f) return 1.0f;
  const double u = unit_open_zero(splitmix64(key ^ 0xA0761D6478BD642Full));
  const double rayleigh = std::sqrt(-std::log(u)) * (2.0 / std::sqrt(std::numbers::pi));
  return static_cast<float>((1.0 - contrast) + contrast * rayleigh);
}

}  // namespace ioct::sim
