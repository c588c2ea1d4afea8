// Helpers of the processing tests: a slot header for a synthetic group, and measures of an
// A-scan (where its peak is, how wide it is).
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>

#include "ioct/gpu/processing/oct_processor.hpp"
#include "synthetic_spectra.hpp"

namespace ioct::gpu::testing {

inline shm::SlotHeader header_for(const shm::RingGeometry& g, std::uint32_t active_begin,
                                  std::uint32_t active_end, std::uint64_t group_index = 7) {
  shm::SlotHeader h{};
  h.group_index = group_index;
  h.payload_bytes = g.group_payload_bytes();
  h.bscan_count = g.bscans_per_group;
  h.active_ascan_begin = active_begin;
  h.active_ascan_end = active_end;
  for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
    h.bscans[b] = marker_for(0, b, g.bscans_per_volume, false);
  }
  return h;
}

inline std::uint32_t brightest_depth(std::span<const std::uint8_t> ascan) {
  return static_cast<std::uint32_t>(std::ranges::max_element(ascan) - ascan.begin());
}

// Pixels within `levels` u8 steps of the brightest one, in the run around it: the peak's width.
inline std::uint32_t peak_width(std::span<const std::uint8_t> ascan, int levels) {
  const std::uint32_t peak = brightest_depth(ascan);
  const int floor = ascan[peak] - levels;
  std::uint32_t begin = peak;
  std::uint32_t end = peak + 1;
  while (begin > 0 && ascan[begin - 1] >= floor) --begin;
  while (end < ascan.size() && ascan[end] >= floor) ++end;
  return end - begin;
}

// A-scan `a` of output B-scan `b`.
inline std::span<const std::uint8_t> ascan_of(const ProcessedGroup& out, std::uint32_t b,
                                              std::uint32_t a) {
  return out.bscan(b).subspan(std::size_t{a} * out.depth, out.depth);
}

inline OctProcessorConfig quick_config(std::uint32_t threads = 1) {
  OctProcessorConfig config;
  config.fft.rigor = FftRigor::estimate;
  config.threads = threads;
  return config;
}

}  // namespace ioct::gpu::testing
