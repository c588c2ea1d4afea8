// One output pixel of every mode, written once for both renderers. A Sampler gives the volume's
// intensity in [0, 1] at a voxel position (x: A-scan, y: B-scan, z: depth px; trilinear, edges
// clamped): the CPU reference interpolates in plain code, CUDA reads a 3D texture. A Skipper may
// jump over samples that cannot contribute (empty bricks); skipping keeps the sample positions
// of the unskipped samples, so the image does not depend on it.
#pragma once

#include "ioct/gpu/render/host_device.hpp"
#include "ioct/gpu/render/render_params.hpp"

namespace ioct::gpu::render {

struct Rgba {
  float r, g, b, a;
};

// Never skips: the CPU reference.
struct NoSkip {
  IOCT_HD int next_sample(Vec3, Vec3, float, float, int k) const { return k; }
};

IOCT_HD Rgba transfer_lookup(const float* lut, float intensity) {
  const float x = clamp01(intensity) * (kTransferLutSize - 1);
  const int i0 = static_cast<int>(floorf(x));
  const int i1 = i0 + 1 < kTransferLutSize ? i0 + 1 : i0;
  const float f = x - static_cast<float>(i0);
  const float* a = lut + 4 * i0;
  const float* b = lut + 4 * i1;
  return {lerp(a[0], b[0], f), lerp(a[1], b[1], f), lerp(a[2], b[2], f), lerp(a[3], b[3], f)};
}

// The L*a*b* map as sRGB in [0, 1], bilinear in intensity and delta*.
IOCT_HD Vec3 lab_lookup(const float* lut, float intensity, float delta_star) {
  const float x = clamp01(intensity) * (kLabLutIntensities - 1);
  const float y = clamp01(delta_star) * (kLabLutDepths - 1);
  const int x0 = static_cast<int>(floorf(x));
  const int y0 = static_cast<int>(floorf(y));
  const int x1 = x0 + 1 < kLabLutIntensities ? x0 + 1 : x0;
  const int y1 = y0 + 1 < kLabLutDepths ? y0 + 1 : y0;
  const float fx = x - static_cast<float>(x0);
  const float fy = y - static_cast<float>(y0);
  const float* p00 = lut + 4 * (y0 * kLabLutIntensities + x0);
  const float* p01 = lut + 4 * (y0 * kLabLutIntensities + x1);
  const float* p10 = lut + 4 * (y1 * kLabLutIntensities + x0);
  const float* p11 = lut + 4 * (y1 * kLabLutIntensities + x1);
  Vec3 c;
  c.x = lerp(lerp(p00[0], p01[0], fx), lerp(p10[0], p11[0], fx), fy);
  c.y = lerp(lerp(p00[1], p01[1], fx), lerp(p10[1], p11[1], fx), fy);
  c.z = lerp(lerp(p00[2], p01[2], fx), lerp(p10[2], p11[2], fx), fy);
  return c;
}

// delta* = clamp((delta + 1) / 3) with delta = (depth - reference) / d_rpe (Weiss Sec. 3.1).
IOCT_HD float delta_star(float depth_px, float reference_px, float d_rpe_px) {
  return clamp01(((depth_px - reference_px) / d_rpe_px + 1.0f) / 3.0f);
}

// Bilinear lookup in a w x h float image at (x, y) in texel units, edges clamped.
IOCT_HD float bilinear(const float* image, int w, int h, float x, float y) {
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

// The reference surface (RPE or the axial plane) at a lateral position, bilinear, edges clamped.
IOCT_HD float reference_at(const RenderParams& p, float a, float b) {
  return bilinear(p.reference_px, p.dim_a, p.dim_b, a, b);
}

// Linear opacity transfer function of the layer-aware DVR: 0 up to i_min, alpha_max from i_max.
IOCT_HD float layer_opacity(const RenderParams& p, float intensity) {
  return p.alpha_max * clamp01((intensity - p.i_min) / (p.i_max - p.i_min));
}

// Central differences over one voxel along each axis, turned into a world-space gradient
// (intensity per finest voxel spacing; z up, so the depth difference changes sign).
template <class Sampler>
IOCT_HD Vec3 gradient_at(const RenderParams& p, const Sampler& s, Vec3 v) {
  const float gx = 0.5f * (s(v.x + 1, v.y, v.z) - s(v.x - 1, v.y, v.z));
  const float gy = 0.5f * (s(v.x, v.y + 1, v.z) - s(v.x, v.y - 1, v.z));
  const float gz = 0.5f * (s(v.x, v.y, v.z + 1) - s(v.x, v.y, v.z - 1));
  return {gx * p.gradient_scale.x, gy * p.gradient_scale.y, gz * p.gradient_scale.z};
}

// Ray parameter range [t_near, t_far] inside the volume's box [-0.5, n - 0.5] (voxel space).
IOCT_HD bool intersect_box(const RenderParams& p, Vec3 o, Vec3 d, float& t_near, float& t_far) {
  const float lo[3] = {-0.5f, -0.5f, -0.5f};
  const float hi[3] = {static_cast<float>(p.dim_a) - 0.5f, static_cast<float>(p.dim_b) - 0.5f,
                       static_cast<float>(p.dim_d) - 0.5f};
  const float oo[3] = {o.x, o.y, o.z};
  const float dd[3] = {d.x, d.y, d.z};
  t_near = -1e30f;
  t_far = 1e30f;
  for (int i = 0; i < 3; ++i) {
    if (fabsf(dd[i]) < 1e-12f) {
      if (oo[i] < lo[i] || oo[i] > hi[i]) return false;
      continue;
    }
    float t0 = (lo[i] - oo[i]) / dd[i];
    float t1 = (hi[i] - oo[i]) / dd[i];
    if (t0 > t1) {
      const float t = t0;
      t0 = t1;
      t1 = t;
    }
    t_near = fmaxf(t_near, t0);
    t_far = fminf(t_far, t1);
  }
  return t_far > t_near;
}

IOCT_HD bool inside_box(const RenderParams& p, Vec3 v) {
  return v.x >= -0.5f && v.y >= -0.5f && v.z >= -0.5f &&
         v.x <= static_cast<float>(p.dim_a) - 0.5f && v.y <= static_cast<float>(p.dim_b) - 0.5f &&
         v.z <= static_cast<float>(p.dim_d) - 0.5f;
}

// Front-to-back compositing of one sample (Viehland Eq. 1, the product over the samples in
// front of it).
IOCT_HD void composite(Rgba& acc, Vec3 c, float alpha) {
  const float w = (1.0f - acc.a) * alpha;
  acc.r += w * c.x;
  acc.g += w * c.y;
  acc.b += w * c.z;
  acc.a += w;
}

IOCT_HD Rgba over_background(const RenderParams& p, Rgba acc) {
  const float t = 1.0f - acc.a;
  return {acc.r + t * p.background[0], acc.g + t * p.background[1], acc.b + t * p.background[2],
          acc.a};
}

// The opacity a shadow ray accumulates: the layer-aware DVR's linear ramp, or (axial colorization
// with shadow rays, Weiss Fig. 4 B4) the enhanced transfer function's, below the threshold 0.
struct LayerOpacity {
  const RenderParams& p;
  IOCT_HD float operator()(float intensity) const { return layer_opacity(p, intensity); }
};
struct TransferOpacity {
  const RenderParams& p;
  IOCT_HD float operator()(float intensity) const {
    if (p.use_threshold && intensity < p.threshold) return 0.0f;
    return transfer_lookup(p.transfer_lut, intensity).a;
  }
};

// Shadow factor s(p) (Weiss Eq. 3): transmittance over N_s steps towards the light, from the
// first step beyond the sample; stops at the volume's edge or once it is below 1/1000. (Skipping
// empty bricks here was measured slower: shadow rays start in tissue and rarely meet one.)
//
// The samples are fetched kShadowBatch at a time, then taken in order: the same products in the
// same order, so the same result, but the fetches of a batch are in flight together instead of
// each waiting for the test of the one before (on the GPU a shadow ray was a chain of texture
// latencies). Samples past the end are fetched and not used. H100, 1024^2 frames: N_s = 200
// 2.89 ms one by one, 2.02 in batches of 4, 1.99 of 8, 2.14 of 16; N_s = 20 0.59, 0.49, 0.52,
// 0.65 ms.
inline constexpr int kShadowBatch = 8;
template <class Sampler, class Opacity>
IOCT_HD float shadow_factor(const RenderParams& p, const EyeParams& e, const Sampler& s, Vec3 v,
                            const Opacity& opacity) {
  float transmittance = 1.0f;
  for (int first = 1; first <= p.shadow_steps; first += kShadowBatch) {
    float sample[kShadowBatch];
    bool inside[kShadowBatch];
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (int j = 0; j < kShadowBatch; ++j) {
      const int i = first + j;
      const Vec3 q = v + (static_cast<float>(i) * e.step) * e.light_voxel;
      inside[j] = i <= p.shadow_steps && inside_box(p, q);
      sample[j] = inside[j] ? s(q.x, q.y, q.z) : 0.0f;
    }
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (int j = 0; j < kShadowBatch; ++j) {
      if (!inside[j]) return transmittance;
      transmittance *= 1.0f - opacity(sample[j]);
      if (transmittance < 1e-3f) return transmittance;
    }
  }
  return transmittance;
}

// One ray of the volume modes (basic, enhanced, layer-aware, axial colorization).
template <class Sampler, class Skipper>
IOCT_HD Rgba render_ray(const RenderParams& p, const Sampler& s, const Skipper& skip, int x, int y,
                        int eye_index) {
  const EyeParams& e = p.eye[eye_index];
  const float sx =
      ((static_cast<float>(x) + 0.5f) / static_cast<float>(p.width) * 2.0f - 1.0f) * p.half_width +
      p.pan_x;
  const float sy = (1.0f - (static_cast<float>(y) + 0.5f) / static_cast<float>(p.height) * 2.0f) *
                       p.half_height +
                   p.pan_y;
  const Vec3 o = e.origin + sx * e.right + sy * e.up;
  Rgba acc{0, 0, 0, 0};
  float t_near, t_far;
  if (!intersect_box(p, o, e.dir, t_near, t_far)) return over_background(p, acc);
  const int samples = static_cast<int>(ceilf((t_far - t_near) / e.step - 0.5f));
  const bool layer = p.kind == PixelKind::layer_aware;
  const float termination = p.early_termination;
  const float d_rpe_px = d_rpe(p);  // once per ray: on the device it is a load
  for (int k = 0; k < samples; ++k) {
    const float t = t_near + (static_cast<float>(k) + 0.5f) * e.step;
    const Vec3 v = o + t * e.dir;
    const int next = skip.next_sample(v, e.dir, t_near, e.step, k);
    if (next != k) {
      k = next - 1;
      continue;
    }
    const float intensity = s(v.x, v.y, v.z);
    if (layer) {
      const float alpha = layer_opacity(p, intensity);
      if (alpha <= 0.0f) continue;
      const float ds = delta_star(v.z, reference_at(p, v.x, v.y), d_rpe_px);
      Vec3 c = lab_lookup(p.lab_lut, intensity, ds);
      if (p.shadow_steps > 0) c = shadow_factor(p, e, s, v, LayerOpacity{p}) * c;
      composite(acc, c, alpha);
    } else {
      if (p.use_threshold && intensity < p.threshold) continue;
      const Rgba tf = transfer_lookup(p.transfer_lut, intensity);
      float alpha = tf.a;
      Vec3 c{tf.r, tf.g, tf.b};
      if (p.kind == PixelKind::axial_colorization) {
        c = lab_lookup(p.lab_lut, intensity, delta_star(v.z, reference_at(p, v.x, v.y), d_rpe_px));
      }
      if (p.kind != PixelKind::basic) {
        Vec3 g{0, 0, 0};
        float gm = 0.0f;
        if (p.edge || p.feature || p.phong) {
          g = gradient_at(p, s, v);
          gm = length(g);
        }
        const bool oriented = gm > 1e-6f;
        // Viehland Eq. 2: edge enhancement by the gradient magnitude.
        if (p.edge) alpha *= 1.0f + p.kg1 * powf(gm, p.kg2);
        // Eq. 3: more opacity where the gradient is orthogonal to the view direction.
        if (p.feature && oriented) {
          const float facing = fabsf(dot(g, e.view_world)) / gm;
          alpha *= 1.0f + p.kf1 * powf(fmaxf(1.0f - facing, 0.0f), p.kf2);
        }
        alpha = fminf(alpha, 1.0f);
        // Eq. 4: dimming and a blue hue with the fractional depth dv.
        if (p.depth_cues) {
          const float dv = clamp01((t - e.depth_cue_offset) * e.depth_cue_scale);
          const float w = powf(dv, p.kd2);
          const float keep = 1.0f - p.kd1 * w;
          c = keep * c + (p.kd3 * w) * p.c_b;
        }
        // Eq. 5: Phong with the normal against the gradient (out of the tissue).
        if (p.phong) {
          float light = p.kp1;
          if (oriented) {
            const Vec3 n = (-1.0f / gm) * g;
            light += p.kp2 * fmaxf(dot(n, e.light_world), 0.0f) +
                     p.kp3 * powf(fmaxf(dot(n, e.half_world), 0.0f), p.kp4);
          }
          c = light * c;
        }
        // Weiss Fig. 4 B4: axial colorization shaded by shadow rays instead of Phong.
        if (p.kind == PixelKind::axial_colorization && p.shadow_steps > 0) {
          c = shadow_factor(p, e, s, v, TransferOpacity{p}) * c;
        }
      }
      composite(acc, c, alpha);
    }
    if (acc.a > termination) break;
  }
  acc.r = clamp01(acc.r);
  acc.g = clamp01(acc.g);
  acc.b = clamp01(acc.b);
  return over_background(p, acc);
}

// Intensity at a depth, zero outside the volume's depth range (LA-MIP curves leave it).
template <class Sampler>
IOCT_HD float sample_or_zero(const RenderParams& p, const Sampler& s, float a, float b, float d) {
  if (d < -0.5f || d > static_cast<float>(p.dim_d) - 0.5f) return 0.0f;
  return s(a, b, d);
}

// The slices (B-scan, en face). One eye only; the LA-MIP composite is in la_mip.hpp.
template <class Sampler>
IOCT_HD Rgba render_plane(const RenderParams& p, const Sampler& s, int x, int y) {
  Rgba out{p.background[0], p.background[1], p.background[2], 0.0f};
  const float u = (static_cast<float>(x) + 0.5f - p.plane_x0) * p.plane_scale_x - 0.5f;
  const float w = (static_cast<float>(y) + 0.5f - p.plane_y0) * p.plane_scale_y - 0.5f;
  float i = 0;
  if (p.kind == PixelKind::bscan_slice) {
    if (u < -0.5f || u > static_cast<float>(p.dim_a) - 0.5f || w < -0.5f ||
        w > static_cast<float>(p.dim_d) - 0.5f) {
      return out;
    }
    i = s(u, p.slice_bscan, w);
  } else {
    if (u < -0.5f || u > static_cast<float>(p.dim_a) - 0.5f || w < -0.5f ||
        w > static_cast<float>(p.dim_b) - 0.5f) {
      return out;
    }
    const float d = p.slice_relative_to_rpe ? reference_at(p, u, w) + p.slice_depth : p.slice_depth;
    i = sample_or_zero(p, s, u, w, d);
  }
  return {i, i, i, 1.0f};
}

IOCT_HD unsigned char to_u8(float v) {
  return static_cast<unsigned char>(clamp01(v) * 255.0f + 0.5f);
}

}  // namespace ioct::gpu::render
