// The retinal surfaces of one volume, per A-scan [bscan][ascan], in px of the volume's depth axis
// (0 at the top of a B-scan, increasing downwards; fractional). They travel with the volume so
// that renderers (layer-aware colouring, LA-MIP) and exports use them.
//
//   ilm  inner limiting membrane: the vitreo-retinal interface, at the inner retinal surface's
//        reflex (where the intensity rising from the vitreous reaches ilm_level of the reflex)
//   rpe  centre of the retinal pigment epithelium band: the intensity maximum of the outermost
//        hyper-reflective band of the retina (the RPE/Bruch's membrane complex)
//   bm   Bruch's membrane: where the RPE lies on it, the outer boundary of that band (where the
//        intensity below the RPE centre has fallen half-way to the minimum beneath it); where the
//        RPE is lifted off it (drusen, a small detachment), the floor of the B-scan's BM beneath
//        the lift (lifted_rpe.hpp), inferred
//
// Each A-scan also carries a confidence in [0, 1] (how clear the evidence in its own column is)
// and a state: measured (from the column's own evidence), bridged (evidence too weak, e.g. under
// an instrument's shadow: interpolated from the measured A-scans around it, or carried from an
// earlier volume that measured it) or none (no retina in this B-scan: anterior segment, air, a
// blank or saturated image). Surfaces are NaN for none.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace ioct::gpu::segmentation {

enum class SurfaceState : std::uint8_t {
  none = 0,      // no retina found in this B-scan (or not segmented yet): surfaces NaN
  measured = 1,  // from the A-scan's own evidence
  bridged = 2,   // evidence too weak (shadow, dropout): inferred from measured neighbours or an
                 // earlier volume
};

// What one B-scan held after segmentation.
enum class BscanVerdict : std::uint8_t {
  not_segmented = 0,
  retina = 1,     // a retina was found; its A-scans are measured or bridged
  no_retina = 2,  // too few A-scans with retinal evidence: every surface NaN
};

struct Surfaces {
  static constexpr float kNone = std::numeric_limits<float>::quiet_NaN();

  std::uint32_t bscans = 0;
  std::uint32_t ascans = 0;
  std::uint32_t depth = 0;
  std::vector<float> ilm;         // [bscan][ascan], px
  std::vector<float> rpe;         // px
  std::vector<float> bm;          // px
  std::vector<float> confidence;  // 0..1
  std::vector<SurfaceState> state;
  std::vector<BscanVerdict> verdict;  // [bscan]

  // New dimensions; every A-scan none (NaN), every B-scan not_segmented.
  void reset(std::uint32_t bscan_count, std::uint32_t ascan_count, std::uint32_t depth_px) {
    bscans = bscan_count;
    ascans = ascan_count;
    depth = depth_px;
    const std::size_t n = std::size_t{bscan_count} * ascan_count;
    ilm.assign(n, kNone);
    rpe.assign(n, kNone);
    bm.assign(n, kNone);
    confidence.assign(n, 0.0f);
    state.assign(n, SurfaceState::none);
    verdict.assign(bscan_count, BscanVerdict::not_segmented);
  }

  std::size_t index(std::uint32_t bscan, std::uint32_t ascan) const noexcept {
    return std::size_t{bscan} * ascans + ascan;
  }
  std::size_t size() const noexcept { return std::size_t{bscans} * ascans; }
};

}  // namespace ioct::gpu::segmentation
