// What a segmenter remembers of the volume it works on, between groups: per B-scan the coarse
// RPE (the neighbours' prior) and the background level, and the unsmoothed fits that smoothing
// and bridging read from the B-scans around.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/segmentation/surfaces.hpp"

namespace ioct::gpu::segmentation {

struct VolumeMemory {
  std::uint32_t bscans = 0;
  std::uint32_t ascans = 0;
  std::uint32_t depth = 0;
  std::vector<std::int32_t> coarse;        // [bscan][ascan]: cell of the coarse RPE
  std::vector<std::uint8_t> coarse_valid;  // [bscan]: 1 once its coarse search ran
  std::vector<std::uint8_t> floor;         // [bscan]: background level (u8)
  std::vector<float> ilm;                  // [bscan][ascan], unsmoothed
  std::vector<float> rpe;
  std::vector<float> bm;
  std::vector<float> confidence;
  std::vector<std::uint8_t> verdict;  // [bscan]: BscanVerdict

  bool fits(std::uint32_t b, std::uint32_t a, std::uint32_t d) const noexcept {
    return bscans == b && ascans == a && depth == d;
  }
  void reset(std::uint32_t b, std::uint32_t a, std::uint32_t d) {
    bscans = b;
    ascans = a;
    depth = d;
    const std::size_t n = std::size_t{b} * a;
    coarse.assign(n, 0);
    coarse_valid.assign(b, 0);
    floor.assign(b, 0);
    ilm.assign(n, 0.0f);
    rpe.assign(n, 0.0f);
    bm.assign(n, 0.0f);
    confidence.assign(n, 0.0f);
    verdict.assign(b, static_cast<std::uint8_t>(BscanVerdict::not_segmented));
  }
};

}  // namespace ioct::gpu::segmentation
