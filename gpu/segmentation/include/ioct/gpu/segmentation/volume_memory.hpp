// What a segmenter remembers of the volume it works on, between groups: per B-scan the coarse
// RPE (the neighbours' prior) and the background level, and the unsmoothed fits that smoothing
// and bridging read from the B-scans around; across cycles over the volume, each A-scan's last
// measured fits of an earlier cycle, which bridging carries into a shadow (finishing.hpp).
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/segmentation/finishing.hpp"
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
  // What the last finishing gave each A-scan [bscan][ascan] (the surfaces, their kind; the BM
  // before Bruch's membrane is looked for beneath lifted RPE, lifted_rpe.hpp).
  std::vector<float> finished_ilm;
  std::vector<float> finished_rpe;
  std::vector<float> finished_bm;
  std::vector<detail::FinishedKind> finished_kind;
  detail::CycleClock clock;
  std::vector<std::uint32_t> fits_cycle;  // [bscan]: the cycle of its fits; 0: not searched
  // Per A-scan, fits of an earlier cycle (detail::RememberSlots).
  std::vector<float> remembered_ilm;
  std::vector<float> remembered_rpe;
  std::vector<float> remembered_bm;
  std::vector<std::uint32_t> remembered_frame_cycle;
  std::vector<std::uint32_t> remembered_measured_cycle;

  detail::RememberSlots remember_slots() {
    return {remembered_ilm.data(), remembered_rpe.data(), remembered_bm.data(),
            remembered_frame_cycle.data(), remembered_measured_cycle.data()};
  }
  detail::RememberedFits remembered() const {
    return {remembered_ilm.data(),
            remembered_rpe.data(),
            remembered_bm.data(),
            remembered_frame_cycle.data(),
            remembered_measured_cycle.data(),
            fits_cycle.data()};
  }

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
    finished_ilm.assign(n, 0.0f);
    finished_rpe.assign(n, 0.0f);
    finished_bm.assign(n, 0.0f);
    finished_kind.assign(n, detail::FinishedKind::none);
    clock = {};
    fits_cycle.assign(b, 0);
    remembered_ilm.assign(n, 0.0f);
    remembered_rpe.assign(n, 0.0f);
    remembered_bm.assign(n, 0.0f);
    remembered_frame_cycle.assign(n, 0);
    remembered_measured_cycle.assign(n, 0);
  }
};

}  // namespace ioct::gpu::segmentation
