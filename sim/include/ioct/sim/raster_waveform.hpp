// The galvo waveform of a raster, sweep by sweep: what a scan generator writes to a galvo output.
// The simulator's own tools (ioct-sim-record, tests) use it to drive a SimulatedGalvoOutput the
// way ioct-rt drives the real one.
//
// Sweep s counts from the first recorded A-scan of line 0: each line is ascans_per_bscan
// recorded sweeps followed by flyback_sweeps, during which the command returns to the next
// line's start along a raised cosine (and steps y). Bidirectional: odd lines run right to left,
// and the flyback only steps y.
#pragma once

#include <cstdint>
#include <span>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/raster_scan.hpp"

namespace ioct::sim {

struct RasterWaveform {
  hal::RasterScan scan;
  std::uint32_t flyback_sweeps = 26;
  bool bidirectional = false;

  std::uint64_t sweeps_per_bscan() const noexcept {
    return std::uint64_t{scan.ascans_per_bscan} + flyback_sweeps;
  }
  // Whether line `bscan` (counted from the start) is recorded right to left.
  bool reversed(std::uint64_t bscan) const noexcept { return bidirectional && bscan % 2 == 1; }
  // The commanded position at sweep `sweep`.
  hal::GalvoSample at(std::uint64_t sweep) const noexcept;
  // The commanded positions of sweeps [first_sweep, first_sweep + out.size()).
  void fill(std::uint64_t first_sweep, std::span<hal::GalvoSample> out) const noexcept;
};

}  // namespace ioct::sim
