#include "ioct/gpu/render/layer_reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace ioct::gpu::render {

CentreOfMassSums centre_of_mass_sums(const Volume& volume, std::uint32_t first,
                                     std::uint32_t count) {
  CentreOfMassSums sums;
  const std::uint32_t depth = volume.depth();
  for (std::uint32_t b = first; b < first + count && b < volume.bscans(); ++b) {
    const auto pixels = volume.bscan(b);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
      const std::uint8_t v = pixels[i];
      if (v < kCentreOfMassLevel) continue;
      sums.weighted_depth += std::uint64_t{v} * (i % depth);
      sums.weight += v;
    }
  }
  return sums;
}

namespace {

// Fills the NaN entries of one row by linear interpolation, the ends by the nearest value.
// Returns false when the row has no value at all.
bool fill_row(float* row, std::uint32_t n) {
  std::int64_t previous = -1;
  for (std::uint32_t i = 0; i < n; ++i) {
    if (std::isnan(row[i])) continue;
    if (previous < 0) {
      for (std::uint32_t j = 0; j < i; ++j) row[j] = row[i];
    } else {
      const float a = row[previous];
      const float span = static_cast<float>(i - previous);
      for (std::int64_t j = previous + 1; j < i; ++j) {
        row[j] = a + (row[i] - a) * static_cast<float>(j - previous) / span;
      }
    }
    previous = i;
  }
  if (previous < 0) return false;
  for (std::uint32_t j = static_cast<std::uint32_t>(previous) + 1; j < n; ++j)
    row[j] = row[previous];
  return true;
}

}  // namespace

LayerReference make_layer_reference(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth,
                                    const segmentation::Surfaces* surfaces, CentreOfMassSums sums) {
  LayerReference ref;
  ref.bscans = bscans;
  ref.ascans = ascans;
  const std::size_t n = std::size_t{bscans} * ascans;
  const float centre_of_mass_px =
      sums.weight > 0 ? static_cast<float>(static_cast<double>(sums.weighted_depth) /
                                           static_cast<double>(sums.weight))
                      : 0.5f * static_cast<float>(depth);
  ref.axial_plane_px.assign(n, centre_of_mass_px);
  const bool usable = surfaces != nullptr && surfaces->bscans == bscans &&
                      surfaces->ascans == ascans && surfaces->rpe.size() == n;
  if (!usable) {
    ref.rpe_px = ref.axial_plane_px;
    return ref;
  }
  ref.rpe_px = surfaces->rpe;
  double thickness = 0.0;
  std::size_t both = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isnan(surfaces->rpe[i]) && !std::isnan(surfaces->ilm[i])) {
      thickness += surfaces->rpe[i] - surfaces->ilm[i];
      ++both;
    }
  }
  if (both > 0 && thickness > 0.0)
    ref.mean_thickness_px = static_cast<float>(thickness / static_cast<double>(both));
  std::vector<bool> has_row(bscans, false);
  for (std::uint32_t b = 0; b < bscans; ++b)
    has_row[b] = fill_row(ref.rpe_px.data() + std::size_t{b} * ascans, ascans);
  std::int64_t nearest_any = -1;
  for (std::uint32_t b = 0; b < bscans; ++b) {
    if (has_row[b]) nearest_any = b;
  }
  if (nearest_any < 0) {
    ref.rpe_px = ref.axial_plane_px;
    ref.mean_thickness_px = 0.0f;
    return ref;
  }
  for (std::uint32_t b = 0; b < bscans; ++b) {
    if (has_row[b]) continue;
    std::int64_t best = -1;
    for (std::int64_t k = 1; best < 0; ++k) {
      if (b >= k && has_row[b - k])
        best = b - k;
      else if (b + k < bscans && has_row[b + k])
        best = b + k;
    }
    std::copy_n(ref.rpe_px.begin() + best * ascans, ascans,
                ref.rpe_px.begin() + std::size_t{b} * ascans);
  }
  return ref;
}

}  // namespace ioct::gpu::render
