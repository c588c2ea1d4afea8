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
  IOCT_RENDER_HD std::size_t en_face_max() const { return 0; }
  IOCT_RENDER_HD std::size_t en_face_depth() const { return a * b; }
  IOCT_RENDER_HD std::size_t across_bscans() const { return 2 * a * b; }
  IOCT_RENDER_HD std::size_t along_ascans() const { return 2 * a * b + d * a; }
  IOCT_RENDER_HD std::size_t size() const { return 2 * a * b + d * a + d * b; }
};

IOCT_RENDER_HD LaMipBuffer la_mip_buffer(const RenderParams& p) {
  return {static_cast<std::size_t>(p.dim_a), static_cast<std::size_t>(p.dim_b),
          static_cast<std::size_t>(p.dim_d)};
}

// En face MIP of column (a, b): the brightest sample and, among equals, the shallowest. (The CUDA
// renderer reduces a column across a warp to the same result.)
template <class Sampler>
IOCT_RENDER_HD void la_mip_en_face_texel(const RenderParams& p, const Sampler& s, int a, int b,
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

// Eq. 4 across the B-scans: at A-scan a, the maximum over B-scans [b0, b1) along the curve whose
// distance from the RPE is that of panel depth z at the middle B-scan. (Ranges let CUDA split a
// curve over threads; the maximum of the parts is the whole's.) At whole (a, b) the RPE is
// reference_at()'s value without interpolating. Texel (z, a) of the across_bscans() image.
template <class Sampler>
IOCT_RENDER_HD float la_mip_across_bscans(const RenderParams& p, const Sampler& s, int a, int z,
                                          int b0, int b1) {
  const float fa = static_cast<float>(a);
  const float offset = static_cast<float>(z) - reference_at(p, fa, 0.5f * (p.dim_b - 1));
  float best = 0.0f;
  for (int b = b0; b < b1; ++b) {
    const float d = p.reference_px[b * p.dim_a + a] + offset;
    best = fmaxf(best, sample_or_zero(p, s, fa, static_cast<float>(b), d));
  }
  return best;
}

// Eq. 4 along the A-scans [a0, a1) of B-scan b, at the distance from the RPE of panel depth z at
// the middle A-scan. Texel (z, b) of the along_ascans() image.
template <class Sampler>
IOCT_RENDER_HD float la_mip_along_ascans(const RenderParams& p, const Sampler& s, int b, int z,
                                         int a0, int a1) {
  const float fb = static_cast<float>(b);
  const float offset = static_cast<float>(z) - reference_at(p, 0.5f * (p.dim_a - 1), fb);
  const float* rpe = p.reference_px + b * p.dim_a;
  float best = 0.0f;
  for (int a = a0; a < a1; ++a) {
    best = fmaxf(best, sample_or_zero(p, s, static_cast<float>(a), fb, rpe[a] + offset));
  }
  return best;
}

// Bilinear lookup in a w x h image at (x, y) in texel units, edges clamped.
IOCT_RENDER_HD float bilinear(const float* image, int w, int h, float x, float y) {
  x = fminf(fmaxf(x, 0.0f), static_cast<float>(w - 1));
  y = fminf(fmaxf(y, 0.0f), static_cast<float>(h - 1));
  const int x0 = static_cast<int>(floorf(x));
  const int y0 = static_cast<int>(floorf(y));
  const int x1 = x0 + 1 < w ? x0 + 1 : x0;
  const int y1 = y0 + 1 < h ? y0 + 1 : y0;
  const float fx = x - static_cast<float>(x0);
  const float fy = y - static_cast<float>(y0);
  return lerp(lerp(image[y0 * w + x0], image[y0 * w + x1], fx),
              lerp(image[y1 * w + x0], image[y1 * w + x1], fx), fy);
}

// One output pixel of the composite: en face (top left), LA-MIP across the B-scans (below, depth
// down), LA-MIP along the A-scans (right, depth to the right). Eq. 5: colour from the maximum and
// delta* of the curve's distance from the RPE (en face: of the maximum's depth).
IOCT_RENDER_HD Rgba la_mip_composite_pixel(const RenderParams& p, const float* buffer, int x,
                                           int y) {
  const CompositeLayout& l = p.layout;
  const LaMipBuffer layout = la_mip_buffer(p);
  const int px = x - l.x0;
  const int py = y - l.y0;
  const float a_scale = static_cast<float>(p.dim_a) / l.en_face_w;
  const float b_scale = static_cast<float>(p.dim_b) / l.en_face_h;
  const float d_scale = static_cast<float>(p.dim_d) / l.depth_extent;
  float best = 0.0f;
  float ds = 0.0f;
  if (px >= 0 && py >= 0 && px < l.en_face_w && py < l.en_face_h) {
    const float a = (px + 0.5f) * a_scale - 0.5f;
    const float b = (py + 0.5f) * b_scale - 0.5f;
    best = bilinear(buffer + layout.en_face_max(), p.dim_a, p.dim_b, a, b);
    const float depth = bilinear(buffer + layout.en_face_depth(), p.dim_a, p.dim_b, a, b);
    ds = delta_star(depth, reference_at(p, a, b), p.d_rpe_px);
  } else if (px >= 0 && px < l.en_face_w && py >= l.en_face_h &&
             py < l.en_face_h + l.depth_extent) {
    const float a = (px + 0.5f) * a_scale - 0.5f;
    const float z = (py - l.en_face_h + 0.5f) * d_scale - 0.5f;
    best = bilinear(buffer + layout.across_bscans(), p.dim_a, p.dim_d, a, z);
    const float offset = z - reference_at(p, a, 0.5f * (p.dim_b - 1));
    ds = clamp01((offset / p.d_rpe_px + 1.0f) / 3.0f);
  } else if (py >= 0 && py < l.en_face_h && px >= l.en_face_w &&
             px < l.en_face_w + l.depth_extent) {
    const float b = (py + 0.5f) * b_scale - 0.5f;
    const float z = (px - l.en_face_w + 0.5f) * d_scale - 0.5f;
    best = bilinear(buffer + layout.along_ascans(), p.dim_b, p.dim_d, b, z);
    const float offset = z - reference_at(p, 0.5f * (p.dim_a - 1), b);
    ds = clamp01((offset / p.d_rpe_px + 1.0f) / 3.0f);
  } else {
    return {p.background[0], p.background[1], p.background[2], 0.0f};
  }
  const Vec3 c = lab_lookup(p.lab_lut, best, ds);
  return {c.x, c.y, c.z, 1.0f};
}

}  // namespace ioct::gpu::render
