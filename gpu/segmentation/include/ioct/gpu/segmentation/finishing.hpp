// The last step of the segmentation, per A-scan, written once for the CPU and the CUDA kernels:
// from the unsmoothed fits of a B-scan and its neighbours to the surfaces the volume carries.
//
// A measured A-scan (confidence >= min_confidence in a B-scan with a retina) is smoothed over
// its 3 x 3 neighbourhood of measured A-scans (weights 1-2-1 along and across B-scans), leaving
// out neighbours more than smooth_tolerance_px away (another surface, a step). An A-scan of lower
// confidence is bridged from the nearest measured A-scans in four directions: to its left and
// right in its B-scan, above and below at the same A-scan (within bridge_bscans). Each direction
// with measured A-scans on both sides interpolates linearly between them, and weighs
// 1 / (d1 d2) (the error of a linear interpolation grows with the product of the distances); a
// direction with one side only extrapolates along the slope between that side's nearest measured
// A-scan and one kSlopeBaseline further on (constant when there is none), and weighs as if both
// sides were twice as far, 1 / (4 d^2). Distances are lateral micrometres.
//
// A confident fit counts as measured only if the B-scans beside it agree (`agrees_across`): next
// to an instrument's shadow the partly shadowed RPE can lose to a brighter inner band with full
// confidence, since the search along a B-scan must come out of the shadow continuously; its
// neighbours across, outside the shadow, see the RPE where it is. Such a fit is bridged instead.
#pragma once

#include <cmath>
#include <cstdint>

#include "ioct/gpu/cuda/host_device_function.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"

namespace ioct::gpu::segmentation::detail {

// The unsmoothed results of a volume, [bscan][ascan].
struct RawFits {
  const float* ilm = nullptr;
  const float* rpe = nullptr;
  const float* bm = nullptr;
  const float* confidence = nullptr;
  const std::uint8_t* verdict = nullptr;  // [bscan] BscanVerdict
  int bscans = 0;
  int ascans = 0;
};

struct FinishSettings {
  float min_confidence = 0.35f;
  float smooth_tolerance_px = 3.0f;
  float ascan_spacing_um = 1.0f;
  float bscan_spacing_um = 1.0f;
  int bridge_bscans = 16;
  bool smooth = true;
};

// A-scans (or B-scans) between the two measured points an extrapolation takes its slope from.
inline constexpr int kSlopeBaselineAscans = 24;
inline constexpr int kSlopeBaselineBscans = 4;

// One A-scan's surfaces.
struct FinishedAscan {
  float ilm;
  float rpe;
  float bm;
  float confidence;
  SurfaceState state;
};

IOCT_HD bool has_retina(const RawFits& raw, int b) {
  return raw.verdict[b] == static_cast<std::uint8_t>(BscanVerdict::retina);
}

// The B-scans on each side of a fit that `agrees_across` consults; surfaces a B-scan finishes
// depend on fits this much further away than the bridges reach (Segmenter::outputs_affected).
inline constexpr int kAcrossCheckBscans = 2;
// How far (px) the RPE may lie from what its neighbours across predict: twice the smoothing's
// step (a straight line through them allows for a tilt; this for the curvature and the noise).
inline constexpr float kAcrossTolerancePx = 6.0f;

IOCT_HD bool confident(const RawFits& raw, const FinishSettings& s, int b, int a) {
  return has_retina(raw, b) && raw.confidence[b * raw.ascans + a] >= s.min_confidence;
}

IOCT_HD bool near_prediction(float value, float predicted) {
  return fabsf(value - predicted) <= kAcrossTolerancePx;
}

// Whether the RPE at (b, a) agrees with the confident fits at the same A-scan in the B-scans
// beside it: with the mean of the two on either side, or the line through the two on one side,
// or the single one on a side that has only one. True when no neighbour is confident (nothing to
// disagree with: a single B-scan, a wide shadow).
IOCT_HD bool agrees_across(const RawFits& raw, const FinishSettings& s, int b, int a) {
  const float* rpe = raw.rpe;
  const int n = raw.ascans;
  const float r = rpe[b * n + a];
  const bool before1 = b >= 1 && confident(raw, s, b - 1, a);
  const bool before2 = before1 && b >= 2 && confident(raw, s, b - 2, a);
  const bool after1 = b + 1 < raw.bscans && confident(raw, s, b + 1, a);
  const bool after2 = after1 && b + 2 < raw.bscans && confident(raw, s, b + 2, a);
  if (!before1 && !after1) return true;
  if (before1 && after1 &&
      near_prediction(r, 0.5f * (rpe[(b - 1) * n + a] + rpe[(b + 1) * n + a]))) {
    return true;
  }
  if (before2 && near_prediction(r, 2.0f * rpe[(b - 1) * n + a] - rpe[(b - 2) * n + a])) {
    return true;
  }
  if (after2 && near_prediction(r, 2.0f * rpe[(b + 1) * n + a] - rpe[(b + 2) * n + a])) {
    return true;
  }
  if (before1 && !before2 && near_prediction(r, rpe[(b - 1) * n + a])) return true;
  return after1 && !after2 && near_prediction(r, rpe[(b + 1) * n + a]);
}

IOCT_HD bool is_measured(const RawFits& raw, const FinishSettings& s, int b, int a) {
  return confident(raw, s, b, a) && agrees_across(raw, s, b, a);
}

// Weighted mean of one surface over the measured 3 x 3 neighbourhood of (b, a), in a fixed order.
IOCT_HD float smoothed(const float* surface, const RawFits& raw, const FinishSettings& s, int b,
                       int a) {
  const float centre = surface[b * raw.ascans + a];
  float sum = 0.0f;
  float weights = 0.0f;
  for (int db = -1; db <= 1; ++db) {
    const int nb = b + db;
    if (nb < 0 || nb >= raw.bscans) continue;
    for (int da = -1; da <= 1; ++da) {
      const int na = a + da;
      if (na < 0 || na >= raw.ascans) continue;
      if (!is_measured(raw, s, nb, na)) continue;
      const float v = surface[nb * raw.ascans + na];
      if (fabsf(v - centre) > s.smooth_tolerance_px) continue;
      const float w = static_cast<float>((2 - (db < 0 ? -db : db)) * (2 - (da < 0 ? -da : da)));
      sum += w * v;
      weights += w;
    }
  }
  return sum / weights;  // the centre itself always counts
}

// The three surfaces at one place.
struct Triple {
  float ilm = 0.0f;
  float rpe = 0.0f;
  float bm = 0.0f;
};

IOCT_HD Triple triple_at(const RawFits& raw, int index) {
  return {raw.ilm[index], raw.rpe[index], raw.bm[index]};
}

// The bridge in one direction through (b, a): `step_b`, `step_a` is one step of the direction
// (0, 1 along the B-scan, 1, 0 across), `reach` how many steps it looks each way, `spacing_um`
// the length of a step, `baseline` the steps between the two points of an extrapolated slope.
struct DirectionBridge {
  Triple value;
  float weight = 0.0f;
};

IOCT_HD int nearest_measured(const RawFits& raw, const FinishSettings& s, int b, int a, int step_b,
                             int step_a, int first, int reach) {
  for (int k = first; k <= reach; ++k) {
    const int nb = b + k * step_b;
    const int na = a + k * step_a;
    if (nb < 0 || nb >= raw.bscans || na < 0 || na >= raw.ascans) return -1;
    if (is_measured(raw, s, nb, na)) return k;
  }
  return -1;
}

IOCT_HD DirectionBridge bridge_direction(const RawFits& raw, const FinishSettings& s, int b, int a,
                                         int step_b, int step_a, int reach, float spacing_um,
                                         int baseline) {
  DirectionBridge bridge;
  const int ahead = nearest_measured(raw, s, b, a, step_b, step_a, 1, reach);
  const int behind = nearest_measured(raw, s, b, a, -step_b, -step_a, 1, reach);
  if (ahead > 0 && behind > 0) {
    const Triple p = triple_at(raw, (b + ahead * step_b) * raw.ascans + a + ahead * step_a);
    const Triple q = triple_at(raw, (b - behind * step_b) * raw.ascans + a - behind * step_a);
    const float fa = static_cast<float>(ahead);
    const float fb = static_cast<float>(behind);
    bridge.value = {(p.ilm * fb + q.ilm * fa) / (fa + fb), (p.rpe * fb + q.rpe * fa) / (fa + fb),
                    (p.bm * fb + q.bm * fa) / (fa + fb)};
    bridge.weight = 1.0f / (fa * spacing_um * fb * spacing_um);
    return bridge;
  }
  const int sign = ahead > 0 ? 1 : -1;
  const int near = ahead > 0 ? ahead : behind;
  if (near <= 0) return bridge;
  const int nb = b + sign * near * step_b;
  const int na = a + sign * near * step_a;
  const Triple p = triple_at(raw, nb * raw.ascans + na);
  bridge.value = p;
  // The slope between the nearest measured point and one `baseline` further on, if measured.
  const int far = near + baseline;
  const int fb_index = b + sign * far * step_b;
  const int fa_index = a + sign * far * step_a;
  if (fb_index >= 0 && fb_index < raw.bscans && fa_index >= 0 && fa_index < raw.ascans &&
      is_measured(raw, s, fb_index, fa_index)) {
    const Triple q = triple_at(raw, fb_index * raw.ascans + fa_index);
    const float t = static_cast<float>(near) / static_cast<float>(baseline);
    bridge.value = {p.ilm + (p.ilm - q.ilm) * t, p.rpe + (p.rpe - q.rpe) * t,
                    p.bm + (p.bm - q.bm) * t};
  }
  const float d = static_cast<float>(near) * spacing_um;
  bridge.weight = 0.25f / (d * d);
  return bridge;
}

IOCT_HD FinishedAscan finish_ascan(const RawFits& raw, const FinishSettings& s, int b, int a) {
  const float nan = NAN;
  const int i = b * raw.ascans + a;
  if (!has_retina(raw, b)) return {nan, nan, nan, 0.0f, SurfaceState::none};
  const float confidence = raw.confidence[i];
  if (is_measured(raw, s, b, a)) {
    if (!s.smooth) return {raw.ilm[i], raw.rpe[i], raw.bm[i], confidence, SurfaceState::measured};
    return {smoothed(raw.ilm, raw, s, b, a), smoothed(raw.rpe, raw, s, b, a),
            smoothed(raw.bm, raw, s, b, a), confidence, SurfaceState::measured};
  }
  const DirectionBridge along =
      bridge_direction(raw, s, b, a, 0, 1, raw.ascans, s.ascan_spacing_um, kSlopeBaselineAscans);
  const DirectionBridge across = bridge_direction(raw, s, b, a, 1, 0, s.bridge_bscans,
                                                  s.bscan_spacing_um, kSlopeBaselineBscans);
  const float weights = along.weight + across.weight;
  if (weights == 0.0f) return {nan, nan, nan, confidence, SurfaceState::none};
  return {(along.weight * along.value.ilm + across.weight * across.value.ilm) / weights,
          (along.weight * along.value.rpe + across.weight * across.value.rpe) / weights,
          (along.weight * along.value.bm + across.weight * across.value.bm) / weights, confidence,
          SurfaceState::bridged};
}

}  // namespace ioct::gpu::segmentation::detail
