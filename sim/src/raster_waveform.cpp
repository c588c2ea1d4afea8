#include "ioct/sim/raster_waveform.hpp"

#include <cmath>
#include <numbers>

namespace ioct::sim {

hal::GalvoSample RasterWaveform::at(std::uint64_t sweep) const noexcept {
  const std::uint64_t per_line = sweeps_per_bscan();
  const std::uint64_t bscan = sweep / per_line;
  const auto within = static_cast<std::uint32_t>(sweep % per_line);
  const std::uint32_t ascans = scan.ascans_per_bscan;
  const auto line_position = [&](std::uint64_t b, std::uint32_t ascan) {
    const std::uint32_t a = reversed(b) ? ascans - 1 - ascan : ascan;
    const hal::BeamPosition p = scan.position(scan.bscan_in_volume(b), a);
    return hal::GalvoSample{p.x, p.y};
  };
  if (within < ascans) return line_position(bscan, within);
  // Flyback: from this line's last A-scan to the next line's first, along a raised cosine.
  const hal::GalvoSample from = line_position(bscan, ascans - 1);
  const hal::GalvoSample to = line_position(bscan + 1, 0);
  const double f = static_cast<double>(within - ascans + 1) / (flyback_sweeps + 1);
  const double s = 0.5 * (1.0 - std::cos(std::numbers::pi * f));
  return {static_cast<float>(from.x + (to.x - from.x) * s),
          static_cast<float>(from.y + (to.y - from.y) * s)};
}

void RasterWaveform::fill(std::uint64_t first_sweep,
                          std::span<hal::GalvoSample> out) const noexcept {
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = at(first_sweep + i);
}

}  // namespace ioct::sim
