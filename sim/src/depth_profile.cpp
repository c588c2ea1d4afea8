#include "ioct/sim/depth_profile.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

#include "ioct/sim/random.hpp"

namespace ioct::sim {

DepthProfile::DepthProfile(float* values, std::uint32_t grid_points, double grid_per_px,
                           std::uint64_t texture_seed)
    : values_(values),
      grid_points_(grid_points),
      grid_per_px_(grid_per_px),
      grid_per_px_f_(static_cast<float>(grid_per_px)),
      depth_bins_(static_cast<float>(grid_points / grid_per_px)),
      texture_(2 * (std::size_t{kTextureEntries} + 2 * std::size_t{grid_points})),
      phases_(2 * std::size_t{kPhases}) {
  Xoshiro256 rng(texture_seed);
  // Circular complex Gaussian with E|z|^2 = 1: each part has variance 1/2.
  for (float& value : texture_) value = static_cast<float>(rng.normal() * std::sqrt(0.5));
  for (std::uint32_t i = 0; i < kPhases; ++i) {
    const double phase = 2.0 * std::numbers::pi * (i + 0.5) / kPhases;
    phases_[2 * i] = static_cast<float>(std::cos(phase));
    phases_[2 * i + 1] = static_cast<float>(std::sin(phase));
  }
  touched_begin_ = grid_points_;
  touched_end_ = 0;
}

void DepthProfile::begin_column(std::uint64_t lateral_key) noexcept {
  texture_base_ = static_cast<std::uint32_t>(splitmix64(lateral_key) % kTextureEntries);
  texture_origin_ = 0;
  occlusion_point_ = grid_points_;
  transmission_ = 1.0f;
}

void DepthProfile::set_texture_origin(float origin_px) noexcept {
  // Clamped to the grid, so that every texture index stays inside the table.
  const float origin = std::isfinite(origin_px) ? origin_px * grid_per_px_f_ : 0.0f;
  texture_origin_ = std::lround(std::clamp(origin, 0.0f, static_cast<float>(grid_points_)));
}

void DepthProfile::set_occlusion(float depth_px, float transmission) noexcept {
  const float point = std::ceil(depth_px * grid_per_px_f_);
  occlusion_point_ = point <= 0.0f ? 0u
                     : point >= static_cast<float>(grid_points_)
                         ? grid_points_
                         : static_cast<std::uint32_t>(point);
  transmission_ = transmission;
}

void DepthProfile::add_reflector_with_phase(float depth_px, float amplitude,
                                            float phase_rad) noexcept {
  if (!drawable(depth_px) || amplitude == 0.0f) return;
  const auto p = static_cast<std::uint32_t>(std::lround(depth_px * grid_per_px_f_));
  if (p >= grid_points_) return;
  float a = amplitude * gain_[p];
  if (p >= occlusion_point_) a *= transmission_;
  values_[2 * p] += a * std::cos(phase_rad);
  values_[2 * p + 1] += a * std::sin(phase_rad);
  touched_begin_ = std::min(touched_begin_, p);
  touched_end_ = std::max(touched_end_, p + 1);
}

void DepthProfile::add_reflector(float depth_px, float amplitude,
                                 std::uint64_t phase_key) noexcept {
  if (!drawable(depth_px) || amplitude == 0.0f) return;
  const auto p = static_cast<std::uint32_t>(std::lround(depth_px * grid_per_px_f_));
  if (p >= grid_points_) return;
  float a = amplitude * gain_[p];
  if (p >= occlusion_point_) a *= transmission_;
  const std::size_t phase = (splitmix64(phase_key) >> 40) % kPhases;
  values_[2 * p] += a * phases_[2 * phase];
  values_[2 * p + 1] += a * phases_[2 * phase + 1];
  touched_begin_ = std::min(touched_begin_, p);
  touched_end_ = std::max(touched_end_, p + 1);
}

void DepthProfile::add_scatter(float top_px, float bottom_px, float amplitude,
                               float attenuation_per_px) noexcept {
  if (amplitude <= 0.0f || !(bottom_px > top_px)) return;
  const float top = std::max(top_px, 0.0f);
  const float bottom = std::min(bottom_px, depth_bins_);
  if (bottom <= top) return;
  const auto first = static_cast<std::uint32_t>(std::ceil(top * grid_per_px_f_));
  const auto end =
      std::min(grid_points_, static_cast<std::uint32_t>(std::ceil(bottom * grid_per_px_f_)));
  if (first >= end) return;
  // Per grid point amplitude / sqrt(G): the intensity per px does not depend on the grid.
  const float per_point = amplitude / std::sqrt(grid_per_px_f_);
  const float step = std::exp(-attenuation_per_px / grid_per_px_f_);
  float a = per_point *
            std::exp(-attenuation_per_px * (static_cast<float>(first) / grid_per_px_f_ - top_px));
  const std::int64_t offset =
      static_cast<std::int64_t>(texture_base_) + grid_points_ - texture_origin_;
  const float* __restrict texture = texture_.data() + 2 * (offset + first);
  float* __restrict out = values_ + 2 * std::size_t{first};
  const float* __restrict gain = gain_ + first;
  const std::uint32_t count = end - first;
  const std::uint32_t clear =
      occlusion_point_ > first ? std::min(occlusion_point_ - first, count) : 0;
  std::uint32_t n = 0;
  for (; n < clear; ++n) {
    const float g = a * gain[n];
    out[2 * n] += g * texture[2 * n];
    out[2 * n + 1] += g * texture[2 * n + 1];
    a *= step;
  }
  a *= transmission_;
  for (; n < count; ++n) {
    const float g = a * gain[n];
    out[2 * n] += g * texture[2 * n];
    out[2 * n + 1] += g * texture[2 * n + 1];
    a *= step;
  }
  touched_begin_ = std::min(touched_begin_, first);
  touched_end_ = std::max(touched_end_, end);
}

float DepthProfile::drawn_depth(float depth_px) const noexcept {
  return static_cast<float>(static_cast<double>(std::lround(depth_px * grid_per_px_f_)) /
                            grid_per_px_);
}

void DepthProfile::clear() noexcept {
  if (touched_end_ > touched_begin_) {
    std::memset(values_ + 2 * std::size_t{touched_begin_}, 0,
                sizeof(float) * 2 * (touched_end_ - touched_begin_));
  }
  touched_begin_ = grid_points_;
  touched_end_ = 0;
}

}  // namespace ioct::sim
