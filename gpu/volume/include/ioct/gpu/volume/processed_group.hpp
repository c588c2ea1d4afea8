// One group after OCT processing: u8 B-scans [bscan][ascan][depth], depth contiguous, reversed
// lines already flipped, with the markers that say where each B-scan belongs.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu {

struct ProcessedGroup {
  std::uint64_t group_index = 0;
  std::uint64_t producer_epoch = 0;
  std::uint64_t t_publish_ns = 0;  // CLOCK_MONOTONIC, from the slot header
  std::uint32_t bscan_count = 0;
  std::uint32_t ascans = 0;  // the active A-scans of each B-scan
  std::uint32_t depth = 0;
  std::array<shm::BscanMarker, shm::kMaxBscansPerGroup> markers{};
  std::vector<std::uint8_t> pixels;  // bscan_count x ascans x depth; capacity kept between groups

  std::size_t bscan_pixels() const noexcept { return std::size_t{ascans} * depth; }
  std::span<const std::uint8_t> bscan(std::uint32_t b) const noexcept {
    return {pixels.data() + b * bscan_pixels(), bscan_pixels()};
  }
  std::span<std::uint8_t> bscan(std::uint32_t b) noexcept {
    return {pixels.data() + b * bscan_pixels(), bscan_pixels()};
  }
};

}  // namespace ioct::gpu
