// CIE L*a*b* to sRGB (D65 white, IEC 61966-2-1 transfer curve) and the layer-aware colour map of
// Weiss et al. 2019, Eq. (1), baked into the table the renderers read.
#pragma once

#include <array>
#include <vector>

#include "ioct/gpu/render/render_config.hpp"

namespace ioct::gpu::render {

// sRGB components in [0, 1], each clamped into the gamut (no rounding).
std::array<double, 3> lab_to_srgb(double l_star, double a_star, double b_star);

// gamma(I) of Eq. (1) for the chosen curve.
double chroma_scale(ChromaCurve curve, double intensity);

// (L*, a*, b*) of Eq. (1): L* = 100 I, chroma from C0 and C1 at delta* scaled by gamma(I).
std::array<double, 3> layer_color_lab(const LabColorMap& map, double intensity, double delta_star);

// [delta*][I] x RGBA floats (kLabLutDepths x kLabLutIntensities), alpha 1. colorize = false
// gives L* alone (a* = b* = 0).
std::vector<float> bake_lab_lut(const LabColorMap& map, bool colorize);

// kTransferLutSize x RGBA: the colour and opacity transfer functions read through the intensity
// window, linear between points and held constant beyond the first and last.
std::vector<float> bake_transfer_lut(const TransferFunctions& transfer);

}  // namespace ioct::gpu::render
