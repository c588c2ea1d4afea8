// Which filtered volume a render mode is rendered from: the one home of the rule.
//
// Viehland et al. 2016 render from the 3x3x3 median + 5x5 Gaussian volume, and the segmentation
// was tuned on that volume (the instrument detection reads the unfiltered input): the basic and
// enhanced modes and the slices (which show the volume the surfaces were found in) keep it. Weiss
// et al. 2019, Sec. 4, render from "a 3x3 median filter on every B-Scan" without the Gaussian,
// which keeps the small superficial structure (membranes, a flap) that the Gaussian erases: their
// layer-aware ray casting, the LA-MIP composite and the axial colorization of their comparison
// (Fig. 4 B2-B4) are rendered from a second volume, filtered that way from the same input. Their
// segmentation came from a separate tool, and ours loses accuracy on the per-B-scan median
// (docs/segmentation.md), so it stays on the 3D-filtered volume.
#pragma once

#include "ioct/gpu/filters/filter_config.hpp"
#include "ioct/gpu/render/render_config.hpp"

namespace ioct::gpu::live {

// True for the modes rendered from Weiss's 3x3 median per B-scan (no Gaussian).
bool renders_from_bscan_median(render::RenderMode mode) noexcept;

// The filter of the renderer's volume in `mode`: Weiss's per-B-scan median, or
// `segmentation_filter` (the segmentation's volume, shared with the renderer).
filters::VolumeFilterConfig render_filter_for(
    render::RenderMode mode, const filters::VolumeFilterConfig& segmentation_filter);

}  // namespace ioct::gpu::live
