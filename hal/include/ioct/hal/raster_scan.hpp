// A raster's field: where an ideal beam is at each recorded sweep of a volume.
//
// Positions are in scan units: [-1, 1] on each axis spans the scanner's full field. The fast
// axis is x (one B-scan is a line from -extent_x to +extent_x about center_x, recorded left to
// right); the slow axis y steps once per B-scan. The simulator aims its beam here when no galvo is
// attached, and the instrument truth maps positions back to voxels with it. A real (or simulated)
// galvo follows the trajectory that scan/ plans over the same field (scan::plan_raster).
#pragma once

#include <cstdint>

namespace ioct::hal {

enum class ScanPatternKind : std::uint32_t {
  raster = 1,  // unidirectional raster, see RasterScan
};

struct BeamPosition {
  float x = 0.0f;
  float y = 0.0f;
};

struct RasterScan {
  std::uint32_t ascans_per_bscan = 512;   // recorded A-scans of one line
  std::uint32_t bscans_per_volume = 128;  // lines of one volume
  float center_x = 0.0f;                  // scan units
  float center_y = 0.0f;
  float extent_x = 1.0f;  // half-width of the line, scan units
  float extent_y = 1.0f;  // half-height of the volume, scan units

  // Throws ConfigError ("scan.<key>") for zero counts, extents outside [0, 1], or a field that
  // leaves [-1, 1].
  void validate() const;

  std::uint64_t volume_index(std::uint64_t bscan) const noexcept {
    return bscan / bscans_per_volume;
  }
  std::uint32_t bscan_in_volume(std::uint64_t bscan) const noexcept {
    return static_cast<std::uint32_t>(bscan % bscans_per_volume);
  }

  // Commanded beam position of A-scan `ascan` of line `bscan_in_volume`.
  BeamPosition position(std::uint32_t bscan_in_volume, std::uint32_t ascan) const noexcept {
    return {center_x + extent_x * unit_ramp(ascan, ascans_per_bscan),
            center_y + extent_y * unit_ramp(bscan_in_volume, bscans_per_volume)};
  }

 private:
  // i of n evenly over [-1, 1]; a single point sits at 0.
  static float unit_ramp(std::uint32_t i, std::uint32_t n) noexcept {
    return n > 1 ? -1.0f + 2.0f * static_cast<float>(i) / static_cast<float>(n - 1) : 0.0f;
  }
};

}  // namespace ioct::hal
