#include "ioct/gpu/segmentation/segmentation_config.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::segmentation {

void VolumeSampling::validate() const {
  require_real_in_range("sampling.axial_um_per_px", axial_um_per_px, 0.1, 1000.0);
  require_real_in_range("sampling.ascan_spacing_um", ascan_spacing_um, 0.1, 1000.0);
  require_real_in_range("sampling.bscan_spacing_um", bscan_spacing_um, 0.1, 1000.0);
}

void SegmentationConfig::validate() const {
  require_real_in_range("segmentation.retina_max_thickness_um", retina_max_thickness_um, 50.0,
                        5000.0);
  require_real_in_range("segmentation.rpe_depth_prior_um", rpe_depth_prior_um, 0.0, 2000.0);
  require_real_in_range("segmentation.max_slope", max_slope, 0.05, 10.0);
  require_integer_in_range("segmentation.step_penalty", step_penalty, 0, kMaxStepPenalty);
  require_real_in_range("segmentation.ilm_level", ilm_level, 0.1, 1.0);
  require_real_in_range("segmentation.min_confidence", min_confidence, 0.0, 1.0);
  require_real_in_range("segmentation.presence_fraction", presence_fraction, 0.0, 1.0);
  require_integer_in_range("segmentation.min_contrast", min_contrast, 1, 255);
  require_real_in_range("segmentation.min_thickness_um", min_thickness_um, 0.0, 2000.0);
  require_integer_in_range("segmentation.bridge_bscans", bridge_bscans, 0, 64);
  require_real_in_range("segmentation.smooth_tolerance_px", smooth_tolerance_px, 0.0, 100.0);
}

SegmentationParams make_params(const SegmentationConfig& config, const VolumeSampling& sampling,
                               std::uint32_t depth, std::uint32_t ascans) {
  config.validate();
  sampling.validate();
  const auto dims = [&] {
    return std::to_string(ascans) + " A-scans of " + std::to_string(depth) + " px";
  };
  if (depth < kMinDepth || depth > kMaxDepth) {
    throw std::invalid_argument("segmentation: B-scans of " + dims() + ": depth must be in [" +
                                std::to_string(kMinDepth) + ", " + std::to_string(kMaxDepth) +
                                "] px");
  }
  if (ascans == 0 || ascans > kMaxAscans) {
    throw std::invalid_argument("segmentation: B-scans of " + dims() +
                                ": A-scans per B-scan must be in [1, " +
                                std::to_string(kMaxAscans) + "]");
  }
  SegmentationParams p;
  p.depth = static_cast<std::int32_t>(depth);
  p.ascans = static_cast<std::int32_t>(ascans);
  const double band_px = std::ceil(config.retina_max_thickness_um / sampling.axial_um_per_px);
  if (band_px > kMaxBand) {
    throw std::invalid_argument(
        "segmentation: retina_max_thickness_um " + std::to_string(config.retina_max_thickness_um) +
        " at " + std::to_string(sampling.axial_um_per_px) + " um/px is " +
        std::to_string(static_cast<long>(band_px)) + " px; the search handles at most " +
        std::to_string(kMaxBand) + " px");
  }
  p.band = std::min(static_cast<std::int32_t>(band_px), p.depth);
  p.rpe_depth_cap =
      static_cast<std::int32_t>(std::lround(config.rpe_depth_prior_um / sampling.axial_um_per_px));
  const double step_px =
      std::ceil(config.max_slope * sampling.ascan_spacing_um / sampling.axial_um_per_px);
  if (step_px > kMaxStep) {
    throw std::invalid_argument("segmentation: max_slope " + std::to_string(config.max_slope) +
                                " is a step of " + std::to_string(static_cast<long>(step_px)) +
                                " px between A-scans " + std::to_string(sampling.ascan_spacing_um) +
                                " um apart; the search handles at most " +
                                std::to_string(kMaxStep) + " px");
  }
  p.max_step = std::max<std::int32_t>(1, static_cast<std::int32_t>(step_px));
  p.coarse_cells = (p.depth + kCoarseCellPx - 1) / kCoarseCellPx;
  p.coarse_columns = (p.ascans + kCoarsePair - 1) / kCoarsePair;
  p.coarse_step = (kCoarsePair * p.max_step + kCoarseCellPx - 1) / kCoarseCellPx;
  p.step_penalty = static_cast<std::int32_t>(config.step_penalty);
  // The same cost per px of depth per A-scan: a cell is kCoarseCellPx px over kCoarsePair A-scans.
  p.coarse_step_penalty = p.step_penalty * kCoarseCellPx / kCoarsePair;
  p.min_contrast = static_cast<std::int32_t>(config.min_contrast);
  p.min_thickness =
      static_cast<std::int32_t>(std::lround(config.min_thickness_um / sampling.axial_um_per_px));
  p.bridge_bscans = static_cast<std::int32_t>(config.bridge_bscans);
  p.ilm_level = static_cast<float>(config.ilm_level);
  p.min_confidence = static_cast<float>(config.min_confidence);
  p.presence_fraction = static_cast<float>(config.presence_fraction);
  p.smooth_tolerance_px = static_cast<float>(config.smooth_tolerance_px);
  p.smooth = config.smooth;
  return p;
}

}  // namespace ioct::gpu::segmentation
