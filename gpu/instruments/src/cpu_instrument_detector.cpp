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
    std::array<std::uint32_t, 256> histogram{};
    for (const std::uint8_t v : pixels) ++histogram[v];
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
