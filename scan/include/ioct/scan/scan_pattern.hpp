// A planned scan pattern, vortex style: the trajectory (one galvo sample per sweep of a volume,
// flyback included) plus the markers of each B-scan (reversed, commanded positions at the first
// and last active A-scan) and the active A-scan range. Built once, off the real-time thread; the
// acquisition thread only reads it.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/scan/scan_spec.hpp"

namespace ioct::scan {

struct BscanPlan {
  bool reversed = false;   // recorded right to left (the ring's kBscanReversed)
  hal::GalvoSample start;  // commanded position at the first active A-scan
  hal::GalvoSample end;    // commanded position at the last active A-scan
};

// How hard the pattern drives the mirrors: the largest magnitudes on either axis.
struct GalvoUsage {
  double peak_velocity = 0.0;      // scan units per second
  double peak_acceleration = 0.0;  // scan units per second squared
  double peak_position = 0.0;      // largest |x| or |y| commanded
};

struct ScanPattern {
  ScanSpec spec;
  ScanTiming timing;
  std::uint32_t active_begin = 0;  // active records [begin, end) of every B-scan
  std::uint32_t active_end = 0;
  // trajectory[s]: the position for sweep s of the volume (s = bscan * sweeps_per_bscan + sweep
  // in the B-scan; records first, then the flyback); what the beam should be at, before lead
  // compensation.
  std::vector<hal::GalvoSample> trajectory;
  std::vector<BscanPlan> bscans;  // one per B-scan of the volume
  GalvoUsage usage;

  std::uint32_t pattern_id() const noexcept { return static_cast<std::uint32_t>(spec.kind); }
  // The position for sweep `sweep` counted from the start of a volume; volume follows volume.
  hal::GalvoSample at(std::uint64_t sweep) const noexcept {
    return trajectory[sweep % trajectory.size()];
  }
  // The positions of sweeps [first_sweep, first_sweep + out.size()).
  void fill(std::uint64_t first_sweep, std::span<hal::GalvoSample> out) const noexcept {
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = at(first_sweep + i);
  }
  // "raster 128 lines, 1x1 field at (0, 0), 0 deg": for logs and status.
  std::string describe() const;
};

}  // namespace ioct::scan
