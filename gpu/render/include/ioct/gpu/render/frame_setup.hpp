// A RenderConfig turned into what the pixel code reads, for one volume's dimensions: the camera
// of each eye, the coefficients, the image geometry of the planar modes. The tables' pointers are
// left for the renderer to set (host or device copies).
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/render/render_config.hpp"
#include "ioct/gpu/render/render_params.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"  // VolumeDims

namespace ioct::gpu::render {

// `mean_thickness_px`: the layer reference's (LayerReference::mean_thickness_px), 0 when unknown
// here (the CUDA renderer measures it on the device and sets measured_d_rpe_px instead).
// Throws ConfigError for a bad config; std::invalid_argument for an empty volume.
RenderParams bake_params(const RenderConfig& config, VolumeDims dims, float mean_thickness_px);

// Output image size: one eye's width times the eyes, by the height.
std::uint32_t output_width(const RenderParams& params);

// The tables a config needs (transfer function; L*a*b* map, plain or colourised by mode).
struct RenderTables {
  std::vector<float> transfer_lut;
  std::vector<float> lab_lut;
};
RenderTables bake_tables(const RenderConfig& config);

}  // namespace ioct::gpu::render
