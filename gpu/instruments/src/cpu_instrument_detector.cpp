#include "ioct/gpu/instruments/cpu_instrument_detector.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>

namespace ioct::gpu::instruments {

CpuInstrumentDetector::CpuInstrumentDetector(const InstrumentConfig& config,
                                             const VolumeSampling& sampling, unsigned threads)
    : InstrumentDetector(config, sampling), pool_(std::max(1u, threads)) {}

void CpuInstrumentDetector::classify(VolumeRef ref, BscanSpan group, const ColumnParams& params,
                                     InstrumentFindings& findings) {
  if (ref.is_device()) {
    throw std::invalid_argument(
        "instruments: the CPU detection reads host volumes, not a device one");
  }
  const Volume& volume = ref.host();
  pool_.run(group.count, [&](std::uint32_t i, unsigned) {
    const std::uint32_t b = group.first + i;
    const auto pixels = volume.bscan(b);
    // Four partial histograms: most px lie at the floor, and one counter incremented px after px
    // waits on its own last store.
    std::array<std::array<std::uint32_t, 256>, 4> parts{};
    const std::uint8_t* px = pixels.data();
    std::size_t at = 0;
    for (; at + 4 <= pixels.size(); at += 4) {
      ++parts[0][px[at]];
      ++parts[1][px[at + 1]];
      ++parts[2][px[at + 2]];
      ++parts[3][px[at + 3]];
    }
    for (; at < pixels.size(); ++at) ++parts[0][px[at]];
    std::array<std::uint32_t, 256> histogram{};
    for (std::size_t level = 0; level < histogram.size(); ++level) {
      histogram[level] = parts[0][level] + parts[1][level] + parts[2][level] + parts[3][level];
    }
    const int floor_level = median_of_histogram(histogram.data(), pixels.size());
    findings.floor[b] = static_cast<std::uint8_t>(floor_level);
    for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
      const ColumnFinding c =
          classify_column(pixels.data() + std::size_t{a} * volume.depth(), params, floor_level);
      const std::size_t k = findings.index(b, a);
      findings.columns[k] = c.kind;
      findings.reflex_px[k] = c.reflex_px;
      findings.front_px[k] = c.front_px;
    }
  });
}

}  // namespace ioct::gpu::instruments
