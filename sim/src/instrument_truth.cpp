#include "ioct/sim/instrument_truth.hpp"

namespace ioct::sim {
namespace {

// The inverse of RasterScan's ramp: scan units to the index of n points over centre +- extent.
double index_of(double position, double center, double extent, std::uint32_t n) noexcept {
  if (n <= 1 || extent == 0.0) return 0.0;
  return ((position - center) / extent + 1.0) * 0.5 * static_cast<double>(n - 1);
}

}  // namespace

VoxelPoint lateral_voxel(hal::BeamPosition beam, const hal::RasterScan& scan) noexcept {
  return {index_of(beam.y, scan.center_y, scan.extent_y, scan.bscans_per_volume),
          index_of(beam.x, scan.center_x, scan.extent_x, scan.ascans_per_bscan), 0.0};
}

VoxelPoint tip_voxel(const ToolState& state, const hal::RasterScan& scan) noexcept {
  VoxelPoint p = lateral_voxel({state.tip_x, state.tip_y}, scan);
  p.depth_px = state.tip_depth_px;
  return p;
}

}  // namespace ioct::sim
