// One A-scan's complex reflectivity along depth, on the grid the spectrum is synthesised from.
//
// The grid has grid_per_px() points per depth px (px of the processed axis, samples / 2 of them).
// A sample model draws into it, top to bottom:
//   - reflectors: thin interfaces and surfaces, one grid point each, with a random phase (or a
//     given one, for a calibration mirror);
//   - scatter: a layer between two depths filled with fully developed speckle, i.e. an
//     independent complex Gaussian per grid point taken from a frozen texture table, with a mean
//     intensity of amplitude^2 per px and an exponential attenuation inside the layer;
//   - an occlusion: everything drawn below a depth is multiplied by a transmission (the shadow of
//     an instrument).
// Every value is also multiplied by a per-grid-point gain (the source's roll-off). Depths outside
// [0, depth_bins) are not drawn. Nothing here allocates after construction.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace ioct::sim {

class DepthProfile {
 public:
  static constexpr std::uint32_t kTextureEntries = 1u << 17;
  static constexpr std::uint32_t kPhases = 4096;

  // `values`: grid_points interleaved complex floats owned by the caller, all zero.
  // `texture_seed` fixes the speckle texture table.
  DepthProfile(float* values, std::uint32_t grid_points, double grid_per_px,
               std::uint64_t texture_seed);

  std::uint32_t grid_points() const noexcept { return grid_points_; }
  double grid_per_px() const noexcept { return grid_per_px_; }
  float depth_bins() const noexcept { return depth_bins_; }

  // The gain row applied to everything drawn (grid_points values); the synthesizer sets it.
  void set_gain(std::span<const float> gain) noexcept { gain_ = gain.data(); }

  // Starts an A-scan: `lateral_key` picks its speckle (the same key gives the same speckle).
  // Clears the occlusion and anchors the texture at depth 0.
  void begin_column(std::uint64_t lateral_key) noexcept;
  // Anchors the texture at `origin_px`, so that tissue that moves in depth carries its speckle
  // along (a sample model sets it to its top surface).
  void set_texture_origin(float origin_px) noexcept;
  // Everything drawn at or below `depth_px` from now on is multiplied by `transmission`.
  void set_occlusion(float depth_px, float transmission) noexcept;

  // A thin reflector with a random phase drawn from `phase_key`.
  void add_reflector(float depth_px, float amplitude, std::uint64_t phase_key) noexcept;
  // A thin reflector with the phase `phase_rad`.
  void add_reflector_with_phase(float depth_px, float amplitude, float phase_rad) noexcept;
  // Speckle between top_px and bottom_px: mean intensity amplitude^2 per px at the top, falling
  // as exp(-2 attenuation_per_px * depth) in intensity below it.
  void add_scatter(float top_px, float bottom_px, float amplitude,
                   float attenuation_per_px) noexcept;

  // The depth at which a reflector at `depth_px` is drawn (the nearest grid point).
  float drawn_depth(float depth_px) const noexcept;
  bool drawable(float depth_px) const noexcept {
    return depth_px >= 0.0f && depth_px < depth_bins_;
  }

  // For the synthesizer: the range written since the last clear, and clearing it.
  bool empty() const noexcept { return touched_end_ <= touched_begin_; }
  void clear() noexcept;

 private:
  float* values_;
  std::uint32_t grid_points_;
  double grid_per_px_;
  float grid_per_px_f_;
  float depth_bins_;
  const float* gain_ = nullptr;
  std::vector<float> texture_;  // interleaved complex, kTextureEntries + 2 grid_points values
  std::vector<float> phases_;   // interleaved unit phasors
  std::uint32_t texture_base_ = 0;
  std::int64_t texture_origin_ = 0;
  std::uint32_t occlusion_point_ = 0;
  float transmission_ = 1.0f;
  std::uint32_t touched_begin_ = 0;
  std::uint32_t touched_end_ = 0;
};

}  // namespace ioct::sim
