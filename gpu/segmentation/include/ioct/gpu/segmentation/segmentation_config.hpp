// What the segmentation needs to know: the volume's sampling (to turn physical limits into px)
// and the settings of the search. The defaults suit the default geometry (512 A-scans over 6 mm,
// 128 B-scans, 688 px of 5.61 um) and a Spectralis B-scan alike; see docs/segmentation.md.
#pragma once

#include <cstdint>

namespace ioct::gpu::segmentation {

// How the volume samples the eye.
struct VolumeSampling {
  double axial_um_per_px = 5.605;   // depth px, as the volume's source states it
  double ascan_spacing_um = 11.74;  // between neighbouring A-scans of a B-scan
  double bscan_spacing_um = 47.24;  // between neighbouring B-scans

  // Throws ConfigError ("sampling.<key>"): each in [0.1, 1000] um.
  void validate() const;
};

struct SegmentationConfig {
  // Largest ILM-to-RPE distance searched (um of the depth axis). The RPE is searched in the band
  // [ILM, ILM + this]; the ILM in the band of the same height above the coarse RPE.
  double retina_max_thickness_um = 700.0;
  // The RPE search favours depth below the ILM, one unit of evidence per px, up to this depth:
  // the inner retina's reflex can be as bright as the RPE, the RPE lies deeper.
  double rpe_depth_prior_um = 200.0;
  // Bounded slope of both surfaces along a B-scan: depth um per lateral um (1.2 is 50 degrees).
  // Sets the largest step between neighbouring A-scans, ceil(slope x spacing / axial px).
  double max_slope = 1.2;
  // Cost of a step between neighbouring A-scans, per px, in units of the u8 evidence.
  std::uint32_t step_penalty = 8;
  // ILM position: where the intensity rising from the vitreous reaches this share of the way
  // from the vitreous level to the inner retinal reflex's peak.
  double ilm_level = 0.8;
  // A-scans whose evidence gives a confidence below this are bridged from measured neighbours.
  double min_confidence = 0.35;
  // A B-scan holds a retina when at least this share of its A-scans has confidence >= 0.5 ...
  double presence_fraction = 0.2;
  // ... and the median RPE contrast over its A-scans is at least this many u8 levels above the
  // B-scan's background.
  std::uint32_t min_contrast = 20;
  // ... and its median ILM-to-RPE distance is at least this (um of the depth axis): a retina is
  // thicker than a cornea's epithelium, whose surface and Bowman's layer would pass for both.
  double min_thickness_um = 100.0;
  // Bridging looks this many B-scans to each side for measured A-scans (and along the whole
  // B-scan).
  std::uint32_t bridge_bscans = 16;
  // Smoothing of measured A-scans over their 3 x 3 neighbourhood (B-scans and A-scans, weights
  // 1-2-1), ignoring neighbours more than this many px away.
  bool smooth = true;
  double smooth_tolerance_px = 3.0;

  // Throws ConfigError naming the first bad key ("segmentation.<key>").
  void validate() const;
};

// The settings in px for one volume's dimensions: what the CPU and CUDA code read.
struct SegmentationParams {
  std::int32_t depth = 0;
  std::int32_t ascans = 0;
  std::int32_t band = 0;            // states of the fine ILM and RPE searches
  std::int32_t rpe_depth_cap = 0;   // px below the ILM up to which the RPE search rewards depth
  std::int32_t max_step = 0;        // px between neighbouring A-scans
  std::int32_t coarse_cells = 0;    // depth / kCoarseCellPx, rounded up
  std::int32_t coarse_columns = 0;  // ascans / kCoarsePair, rounded up
  std::int32_t coarse_step = 0;     // cells between neighbouring pairs of A-scans
  std::int32_t step_penalty = 0;
  std::int32_t coarse_step_penalty = 0;
  std::int32_t min_contrast = 0;
  std::int32_t min_thickness = 0;  // px
  std::int32_t bridge_bscans = 0;
  float ilm_level = 0.8f;
  float min_confidence = 0.35f;
  float presence_fraction = 0.2f;
  float smooth_tolerance_px = 3.0f;
  bool smooth = true;
};

// Depth px per cell of the coarse search, and A-scans per column of it.
inline constexpr std::int32_t kCoarseCellPx = 4;
inline constexpr std::int32_t kCoarsePair = 2;
// Limits of what the searches handle (the CUDA kernels size their shared memory and blocks by
// them: the coarse search runs one thread per cell in each half, 2048 px are 512 cells).
inline constexpr std::uint32_t kMaxDepth = 2048;
inline constexpr std::uint32_t kMaxAscans = 4096;
inline constexpr std::int32_t kMaxBand = 256;
inline constexpr std::int32_t kMaxStep = 16;
inline constexpr std::int32_t kMaxStepPenalty = 255;  // segmentation.step_penalty
inline constexpr std::uint32_t kMinDepth = 32;

// The px settings for volumes of `depth` px and `ascans` A-scans per B-scan. Throws ConfigError
// for a bad config or sampling, std::invalid_argument for dimensions outside the limits above or
// a band or step larger than the searches handle.
SegmentationParams make_params(const SegmentationConfig& config, const VolumeSampling& sampling,
                               std::uint32_t depth, std::uint32_t ascans);

}  // namespace ioct::gpu::segmentation
