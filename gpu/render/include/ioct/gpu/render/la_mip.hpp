// The Layer-Adjusted MIP composite (Weiss et al. 2019, Sec. 3.3, Eqs. 4-5, Fig. 5), written once
// for both renderers, in two steps:
//  1. three projections at the volume's own lateral resolution, made when the volume or its RPE
//     changes: the en face MIP per A-scan column (maximum and its depth), and the two LA-MIPs per
//     lateral position and panel depth (the maximum along a curve at a constant distance from the
//     RPE, across the B-scans and along the A-scans);
//  2. each output pixel reads them bilinearly and colours them with the L*a*b* map.
// The projections depend on neither the view nor the colours, so a re-render between
// acquisitions costs only step 2, and step 1 samples the volume once per voxel column instead of
// once per output pixel (the output oversamples the volume laterally).
#pragma once

#include <cstddef>

#include "ioct/gpu/render/pixel_shader.hpp"

namespace ioct::gpu::render {

// One float buffer: en face maximum [b][a], en face depth of that maximum [b][a] (px), LA-MIP
// across the B-scans [z][a], LA-MIP along the A-scans [z][b]; z is the panel's depth in px.
struct LaMipBuffer {
  std::size_t a, b, d;
  IOCT_HD std::size_t en_face_max() const { return 0; }
  IOCT_HD std::size_t en_face_depth() const { return a * b; }
  IOCT_HD std::size_t across_bscans() const { return 2 * a * b; }
  IOCT_HD std::size_t along_ascans() const { return 2 * a * b + d * a; }
  IOCT_HD std::size_t size() const { return 2 * a * b + d * a + d * b; }
};

IOCT_HD LaMipBuffer la_mip_buffer(const RenderParams& p) {
  return {static_cast<std::size_t>(p.dim_a), static_cast<std::size_t>(p.dim_b),
          static_cast<std::size_t>(p.dim_d)};
}

// En face MIP of column (a, b): the brightest sample and, among equals, the shallowest. (The CUDA
// renderer reduces a column across a warp to the same result.)
template <class Sampler>
IOCT_HD void la_mip_en_face_texel(const RenderParams& p, const Sampler& s, int a, int b,
                                  float* buffer) {
  float best = 0.0f;
  int best_d = 0;
  for (int d = 0; d < p.dim_d; ++d) {
    const float i = s(static_cast<float>(a), static_cast<float>(b), static_cast<float>(d));
    if (i > best) {
      best = i;
      best_d = d;
    }
  }
  const LaMipBuffer l = la_mip_buffer(p);
  const std::size_t i = static_cast<std::size_t>(b) * l.a + static_cast<std::size_t>(a);
  buffer[l.en_face_max() + i] = best;
  buffer[l.en_face_depth() + i] = static_cast<float>(best_d);
}

// Which of the two LA-MIPs: the curves run across the B-scans (at one A-scan) or along the
// A-scans (of one B-scan).
enum class LaMipAxis { across_bscans, along_ascans };

// Eq. 4: at lateral position `at` (an A-scan, or a B-scan) and panel depth z, the maximum over
// curve samples [k0, k1) (B-scans, or A-scans) along the curve whose distance from the RPE is
// that of z at the middle of the curve. (Ranges let CUDA split a curve over threads; the maximum
// of the parts is the whole's.) At whole (a, b) the RPE is reference_at()'s value without
// interpolating.
template <class Sampler>
IOCT_HD float la_mip_curve_max(const RenderParams& p, const Sampler& s, LaMipAxis axis, int at,
                               int z, int k0, int k1) {
  const bool across = axis == LaMipAxis::across_bscans;
  const float fat = static_cast<float>(at);
  const float middle = across ? reference_at(p, fat, 0.5f * static_cast<float>(p.dim_b - 1))
                              : reference_at(p, 0.5f * static_cast<float>(p.dim_a - 1), fat);
  const float offset = static_cast<float>(z) - middle;
  float best = 0.0f;
  for (int k = k0; k < k1; ++k) {
    const int a = across ? at : k;
    const int b = across ? k : at;
    const float d = p.reference_px[b * p.dim_a + a] + offset;
    best = fmaxf(best, sample_or_zero(p, s, static_cast<float>(a), static_cast<float>(b), d));
  }
  return best;
}

// Where texel (z, at) of `axis`'s LA-MIP image lies in the buffer; how many lateral positions
// that image has, and how many samples its curves.
IOCT_HD std::size_t la_mip_texel(const LaMipBuffer& l, LaMipAxis axis, int at, int z) {
  return axis == LaMipAxis::across_bscans
             ? l.across_bscans() + static_cast<std::size_t>(z) * l.a + static_cast<std::size_t>(at)
             : l.along_ascans() + static_cast<std::size_t>(z) * l.b + static_cast<std::size_t>(at);
}
IOCT_HD int la_mip_positions(const RenderParams& p, LaMipAxis axis) {
  return axis == LaMipAxis::across_bscans ? p.dim_a : p.dim_b;
}
IOCT_HD int la_mip_curve_length(const RenderParams& p, LaMipAxis axis) {
  return axis == LaMipAxis::across_bscans ? p.dim_b : p.dim_a;
}

// One output pixel of the composite: en face (top left), LA-MIP across the B-scans (below, depth
// down), LA-MIP along the A-scans (right, depth to the right). Eq. 5: colour from the maximum and
// delta* of the curve's distance from the RPE (en face: of the maximum's depth).
IOCT_HD Rgba la_mip_composite_pixel(const RenderParams& p, const float* buffer, int x, int y) {
  const CompositeLayout& l = p.layout;
  const LaMipBuffer layout = la_mip_buffer(p);
  const int px = x - l.x0;
  const int py = y - l.y0;
  const float a_scale = static_cast<float>(p.dim_a) / static_cast<float>(l.en_face_w);
  const float b_scale = static_cast<float>(p.dim_b) / static_cast<float>(l.en_face_h);
  const float d_scale = static_cast<float>(p.dim_d) / static_cast<float>(l.depth_extent);
  float best = 0.0f;
  float ds = 0.0f;
  if (px >= 0 && py >= 0 && px < l.en_face_w && py < l.en_face_h) {
    const float a = (static_cast<float>(px) + 0.5f) * a_scale - 0.5f;
    const float b = (static_cast<float>(py) + 0.5f) * b_scale - 0.5f;
    best = bilinear(buffer + layout.en_face_max(), p.dim_a, p.dim_b, a, b);
    const float depth = bilinear(buffer + layout.en_face_depth(), p.dim_a, p.dim_b, a, b);
    ds = delta_star(depth, reference_at(p, a, b), d_rpe(p));
  } else if (px >= 0 && px < l.en_face_w && py >= l.en_face_h &&
             py < l.en_face_h + l.depth_extent) {
    const float a = (static_cast<float>(px) + 0.5f) * a_scale - 0.5f;
    const float z = (static_cast<float>(py - l.en_face_h) + 0.5f) * d_scale - 0.5f;
    best = bilinear(buffer + layout.across_bscans(), p.dim_a, p.dim_d, a, z);
    const float offset = z - reference_at(p, a, 0.5f * static_cast<float>(p.dim_b - 1));
    ds = clamp01((offset / d_rpe(p) + 1.0f) / 3.0f);
  } else if (py >= 0 && py < l.en_face_h && px >= l.en_face_w &&
             px < l.en_face_w + l.depth_extent) {
    const float b = (static_cast<float>(py) + 0.5f) * b_scale - 0.5f;
    const float z = (static_cast<float>(px - l.en_face_w) + 0.5f) * d_scale - 0.5f;
    best = bilinear(buffer + layout.along_ascans(), p.dim_b, p.dim_d, b, z);
    const float offset = z - reference_at(p, 0.5f * static_cast<float>(p.dim_a - 1), b);
    ds = clamp01((offset / d_rpe(p) + 1.0f) / 3.0f);
  } else {
    return {p.background[0], p.background[1], p.background[2], 0.0f};
  }
  const Vec3 c = lab_lookup(p.lab_lut, best, ds);
  return {c.x, c.y, c.z, 1.0f};
}

}  // namespace ioct::gpu::render
