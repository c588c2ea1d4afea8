// Where an instrument's tip is in a volume, from the simulator's pose: the ground truth the
// instrument detection (gpu/instruments) is measured against.
//
// The tip is InstrumentModel::tip_state: the pose's tip point (the end of the closed jaws, of the
// needle, of the scraper's paddle, on the tool's axis: the centre of a capsule's end cap), or for
// open forceps the middle of the jaws' ends. Its lateral position maps onto
// the raster as the scan maps A-scans and B-scans onto scan units; its depth is the pose's depth
// on the processed depth axis.
#pragma once

#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/instrument_model.hpp"

namespace ioct::sim {

// Fractional voxel coordinates of a volume [bscan][ascan][depth] (0 = the first B-scan, A-scan,
// px); outside [0, n - 1] when the tip is outside the scanned field.
struct VoxelPoint {
  double bscan = 0.0;
  double ascan = 0.0;
  double depth_px = 0.0;
};

// The tip of `state` (InstrumentModel::tip_state) in a volume acquired with `scan` (one B-scan per
// line, the commanded beam positions; the simulated digitizer's beam follows them exactly without a
// galvo bench).
VoxelPoint tip_voxel(const ToolState& state, const hal::RasterScan& scan) noexcept;

// The lateral position `beam` (scan units) in fractional A-scan and B-scan coordinates of `scan`.
VoxelPoint lateral_voxel(hal::BeamPosition beam, const hal::RasterScan& scan) noexcept;

}  // namespace ioct::sim
