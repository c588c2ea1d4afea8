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
//
// A low-confidence A-scan that an earlier cycle over the volume measured (the previous volume,
// before the instrument moved over it) takes that fit instead of the bridges, moved by the
// retina's axial motion since then (`carried_fit`): see "Carried from earlier cycles" below.
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
  // [bscan][ascan]: 1 where the fit counts as measured (measured_from_fits), filled for the
  // B-scans a finishing reads (measured_span) before it starts: the bridges' walks and the
  // smoothing look up a flag instead of testing a fit and its neighbours across each time.
  const std::uint8_t* measured = nullptr;
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

// How an A-scan was last finished, which decides what its B-scan's next cycle remembers of it.
enum class FinishedKind : std::uint8_t { none = 0, measured = 1, bridged = 2, carried = 3 };

// One A-scan's surfaces.
struct FinishedAscan {
  float ilm;
  float rpe;
  float bm;
  float confidence;
  SurfaceState state;
  FinishedKind kind;
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

IOCT_HD bool measured_from_fits(const RawFits& raw, const FinishSettings& s, int b, int a) {
  return confident(raw, s, b, a) && agrees_across(raw, s, b, a);
}

// The B-scans whose measured flags finishing B-scans [first, end) of `bscans` reads: the bridges
// across reach bridge_bscans each way, their slope kSlopeBaselineBscans further.
struct MeasuredSpan {
  int first = 0;
  int end = 0;
};
IOCT_HD MeasuredSpan measured_span(const FinishSettings& s, int first, int end, int bscans) {
  const int reach = s.bridge_bscans + kSlopeBaselineBscans;
  return {first > reach ? first - reach : 0, end + reach < bscans ? end + reach : bscans};
}

IOCT_HD bool is_measured(const RawFits& raw, int b, int a) {
  return raw.measured[b * raw.ascans + a] != 0;
}

// Which of the 3 x 3 neighbourhood of (b, a) are measured: bit (db + 1) * 3 + (da + 1). Found
// once for the three surfaces a measured A-scan smooths.
IOCT_HD unsigned measured_neighbours(const RawFits& raw, int b, int a) {
  unsigned mask = 0;
  for (int db = -1; db <= 1; ++db) {
    const int nb = b + db;
    if (nb < 0 || nb >= raw.bscans) continue;
    for (int da = -1; da <= 1; ++da) {
      const int na = a + da;
      if (na < 0 || na >= raw.ascans) continue;
      if (is_measured(raw, nb, na)) mask |= 1u << ((db + 1) * 3 + (da + 1));
    }
  }
  return mask;
}

// Weighted mean of one surface over the measured 3 x 3 neighbourhood of (b, a) (`measured`, from
// measured_neighbours), in a fixed order.
IOCT_HD float smoothed(const float* surface, const RawFits& raw, const FinishSettings& s,
                       unsigned measured, int b, int a) {
  const float centre = surface[b * raw.ascans + a];
  float sum = 0.0f;
  float weights = 0.0f;
  for (int db = -1; db <= 1; ++db) {
    for (int da = -1; da <= 1; ++da) {
      if ((measured & (1u << ((db + 1) * 3 + (da + 1)))) == 0) continue;
      const float v = surface[(b + db) * raw.ascans + a + da];
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

IOCT_HD int nearest_measured(const RawFits& raw, int b, int a, int step_b, int step_a, int first,
                             int reach) {
  for (int k = first; k <= reach; ++k) {
    const int nb = b + k * step_b;
    const int na = a + k * step_a;
    if (nb < 0 || nb >= raw.bscans || na < 0 || na >= raw.ascans) return -1;
    if (is_measured(raw, nb, na)) return k;
  }
  return -1;
}

IOCT_HD DirectionBridge bridge_direction(const RawFits& raw, int b, int a, int step_b, int step_a,
                                         int reach, float spacing_um, int baseline) {
  DirectionBridge bridge;
  const int ahead = nearest_measured(raw, b, a, step_b, step_a, 1, reach);
  const int behind = nearest_measured(raw, b, a, -step_b, -step_a, 1, reach);
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
      is_measured(raw, fb_index, fa_index)) {
    const Triple q = triple_at(raw, fb_index * raw.ascans + fa_index);
    const float t = static_cast<float>(near) / static_cast<float>(baseline);
    bridge.value = {p.ilm + (p.ilm - q.ilm) * t, p.rpe + (p.rpe - q.rpe) * t,
                    p.bm + (p.bm - q.bm) * t};
  }
  const float d = static_cast<float>(near) * spacing_um;
  bridge.weight = 0.25f / (d * d);
  return bridge;
}

// ---------------------------------------------------------------------------------------------
// Carried from earlier cycles. Neighbours alone bridge a shadow by interpolation, which cuts
// across whatever the surface does beneath it (a foveal pit under a wide instrument). The same
// A-scan was often measured in an earlier volume, before the instrument moved over it: that fit
// is remembered (the first search of a B-scan in a new cycle keeps what its last finishing found,
// `remember_fit`) and carried, shifted by the retina's axial motion since then, measured by the
// A-scans beside it that were measured then and are now. Still bridged (inferred) for the
// surfaces' users; the CUDA kernels call these same functions.

// Which cycle over the volume a group belongs to: a group that starts at or before the previous
// group's first B-scan starts a new cycle. (Live groups' spans overlap by the filters' reach, so
// a B-scan may be searched twice in one cycle; their first B-scans rise within a volume.)
struct CycleClock {
  std::uint32_t cycle = 0;      // 0: no group since the memory was reset
  std::int32_t last_first = 0;  // all zero: the initial state (the device memsets it)
};

IOCT_HD void advance_cycle(CycleClock& clock, int first) {
  if (clock.cycle == 0 || first <= clock.last_first) ++clock.cycle;
  clock.last_first = first;
}

// A remembered fit is carried for this many cycles after the one that measured it, no longer:
// the motion correction follows the retina axially only, and an instrument that stays put
// leaves its shadow to the neighbours' bridges after that.
inline constexpr std::uint32_t kCarryCycles = 4;
// Measured A-scans each side whose (now - then) differences give the axial motion, nearest first;
// a side with fewer gives none.
inline constexpr int kMotionSamples = 5;
inline constexpr int kMinMotionSamples = 3;
// How differently (px) the ILM and the RPE of a sample may have moved, and the two sides' motions
// may differ: the retina moves as a whole, and an axial move shifts both sides alike.
inline constexpr float kMotionAgreementPx = 3.0f;
// Confident A-scans each side that remember another frame, past which a side stops looking: the
// frame is gone there (bounds the walk of an A-scan whose own frame nothing else shares).
inline constexpr int kMotionSearchOthers = 4 * kMotionSamples;

// Where the fit stage keeps what it remembers of earlier cycles, [bscan][ascan]: each A-scan's
// surfaces in the frame of one cycle (the retina's axial position then), the cycle whose frame
// that is, and the cycle that measured them (0: nothing remembered).
struct RememberSlots {
  float* ilm = nullptr;
  float* rpe = nullptr;
  float* bm = nullptr;
  std::uint32_t* frame = nullptr;
  std::uint32_t* measured = nullptr;
};

// Whether the search of a B-scan whose fits are from cycle `fits_cycle` is its first in `cycle`:
// then, before its fits are replaced, what its last finishing found is remembered.
IOCT_HD bool first_search_in_cycle(std::uint32_t fits_cycle, std::uint32_t cycle) {
  return fits_cycle != 0 && fits_cycle != cycle;
}

// Remembers A-scan i of a B-scan whose fits (`fit`, about to be replaced) are from cycle
// `fits_cycle`, as its last finishing left it: a measured fit as it is; a carried one (the
// `finished` surfaces) still as measured when it was, moved into this cycle's frame, so that the
// next cycle corrects it by the motion since this one, which its neighbours measured fits of now
// show. A bridged one leaves what was remembered.
IOCT_HD void remember_fit(const RememberSlots& slots, int i, std::uint32_t fits_cycle,
                          FinishedKind kind, Triple fit, Triple finished) {
  if (kind == FinishedKind::measured) {
    slots.measured[i] = fits_cycle;
  } else if (kind == FinishedKind::carried) {
    fit = finished;
  } else {
    return;
  }
  slots.ilm[i] = fit.ilm;
  slots.rpe[i] = fit.rpe;
  slots.bm[i] = fit.bm;
  slots.frame[i] = fits_cycle;
}

// The remembered fits as finishing reads them.
struct RememberedFits {
  const float* ilm = nullptr;
  const float* rpe = nullptr;
  const float* bm = nullptr;
  const std::uint32_t* frame = nullptr;       // [bscan][ascan]
  const std::uint32_t* measured = nullptr;    // [bscan][ascan]
  const std::uint32_t* fits_cycle = nullptr;  // [bscan]: the cycle of the B-scan's current fits
};

// Whether A-scan i of B-scan b remembers a fit measured at most kCarryCycles cycles before b's
// current fits.
IOCT_HD bool remembers(const RememberedFits& m, int b, int i) {
  const std::uint32_t then = m.measured[i];
  return then != 0 && m.fits_cycle[b] - then <= kCarryCycles;
}

// Inserts x into the ascending values[0, n).
IOCT_HD void insert_sorted(float* values, int n, float x) {
  int k = n;
  while (k > 0 && values[k - 1] > x) {
    values[k] = values[k - 1];
    --k;
  }
  values[k] = x;
}

IOCT_HD float median_sorted(const float* values, int n) {
  return (n & 1) != 0 ? values[n / 2] : 0.5f * (values[n / 2 - 1] + values[n / 2]);
}

// The retina's axial motion since cycle `frame` on one side of (b, a) in its B-scan: the median
// of (now - then) over the nearest kMotionSamples A-scans measured now and measured in `frame`,
// per surface (one shift for all, the mean of the ILM's and RPE's, measured worse for the ILM:
// shadow ILM mean 0.83 against 0.76 px in Carry.*).
struct SideMotion {
  Triple shift;
  int count = 0;
  int nearest = 0;  // A-scans from a to the nearest of them
};

IOCT_HD SideMotion side_motion(const RawFits& raw, const RememberedFits& m, const FinishSettings& s,
                               int b, int a, int step, std::uint32_t frame) {
  float ilm[kMotionSamples];
  float rpe[kMotionSamples];
  float bm[kMotionSamples];
  SideMotion side;
  int others = 0;
  for (int na = a + step; na >= 0 && na < raw.ascans && side.count < kMotionSamples; na += step) {
    const int j = b * raw.ascans + na;
    if (m.measured[j] != frame || m.frame[j] != frame) {
      if (confident(raw, s, b, na) && ++others > kMotionSearchOthers) break;
      continue;
    }
    if (!is_measured(raw, b, na)) continue;
    // Where the ILM and the RPE moved differently, one of the fits is wrong (next to a shadow the
    // RPE can settle on an inner band with full confidence).
    const float ilm_moved = raw.ilm[j] - m.ilm[j];
    const float rpe_moved = raw.rpe[j] - m.rpe[j];
    if (fabsf(ilm_moved - rpe_moved) > kMotionAgreementPx) continue;
    if (side.count == 0) side.nearest = (na - a) * step;
    insert_sorted(ilm, side.count, ilm_moved);
    insert_sorted(rpe, side.count, rpe_moved);
    insert_sorted(bm, side.count, raw.bm[j] - m.bm[j]);
    ++side.count;
  }
  if (side.count >= kMinMotionSamples) {
    side.shift = {median_sorted(ilm, side.count), median_sorted(rpe, side.count),
                  median_sorted(bm, side.count)};
  }
  return side;
}

// The remembered fit at (b, a) shifted by the axial motion since its frame (the sides' medians,
// interpolated between the two by distance, or the one side that has enough) into `carried`;
// false when there is no remembered fit, no motion to correct it by, two sides that disagree on
// it (not an axial move: the eye or the scan moved sideways, or the memory is wrong), or shifted
// surfaces out of their order (each surface has its own shift).
IOCT_HD bool carried_fit(const RawFits& raw, const RememberedFits& m, const FinishSettings& s,
                         int b, int a, Triple& carried) {
  const int i = b * raw.ascans + a;
  if (!remembers(m, b, i)) return false;
  const SideMotion before = side_motion(raw, m, s, b, a, -1, m.frame[i]);
  const SideMotion after = side_motion(raw, m, s, b, a, 1, m.frame[i]);
  const bool has_before = before.count >= kMinMotionSamples;
  const bool has_after = after.count >= kMinMotionSamples;
  Triple shift;
  if (has_before && has_after) {
    if (fabsf(before.shift.ilm - after.shift.ilm) > kMotionAgreementPx ||
        fabsf(before.shift.rpe - after.shift.rpe) > kMotionAgreementPx) {
      return false;
    }
    const float db = static_cast<float>(before.nearest);
    const float da = static_cast<float>(after.nearest);
    shift = {(before.shift.ilm * da + after.shift.ilm * db) / (da + db),
             (before.shift.rpe * da + after.shift.rpe * db) / (da + db),
             (before.shift.bm * da + after.shift.bm * db) / (da + db)};
  } else if (has_before || has_after) {
    shift = has_before ? before.shift : after.shift;
  } else {
    return false;
  }
  carried = {m.ilm[i] + shift.ilm, m.rpe[i] + shift.rpe, m.bm[i] + shift.bm};
  return carried.ilm <= carried.rpe && carried.rpe <= carried.bm;
}

IOCT_HD FinishedAscan finish_ascan(const RawFits& raw, const RememberedFits& remembered,
                                   const FinishSettings& s, int b, int a) {
  const float nan = NAN;
  const int i = b * raw.ascans + a;
  if (!has_retina(raw, b)) return {nan, nan, nan, 0.0f, SurfaceState::none, FinishedKind::none};
  const float confidence = raw.confidence[i];
  if (is_measured(raw, b, a)) {
    if (!s.smooth) {
      return {raw.ilm[i],
              raw.rpe[i],
              raw.bm[i],
              confidence,
              SurfaceState::measured,
              FinishedKind::measured};
    }
    const unsigned measured = measured_neighbours(raw, b, a);
    return {smoothed(raw.ilm, raw, s, measured, b, a),
            smoothed(raw.rpe, raw, s, measured, b, a),
            smoothed(raw.bm, raw, s, measured, b, a),
            confidence,
            SurfaceState::measured,
            FinishedKind::measured};
  }
  // A carried fit replaces the neighbours' bridges: mixed in with a weight of 1 / d^2 like
  // theirs, the shadows' errors fell the smaller d was (d = 200, 25, 3 um: RPE max 20.0, 10.7,
  // 0.9 px under an open forceps, where the bridges take in the measured but wrong fits beside
  // the shadow; ILM max 32.9, 2.2, 2.0 px over a macular hole's cuff; segmentation_test,
  // Carry.*), and without the bridges it costs less.
  Triple carried;
  if (carried_fit(raw, remembered, s, b, a, carried)) {
    return {carried.ilm, carried.rpe,           carried.bm,
            confidence,  SurfaceState::bridged, FinishedKind::carried};
  }
  const DirectionBridge along =
      bridge_direction(raw, b, a, 0, 1, raw.ascans, s.ascan_spacing_um, kSlopeBaselineAscans);
  const DirectionBridge across =
      bridge_direction(raw, b, a, 1, 0, s.bridge_bscans, s.bscan_spacing_um, kSlopeBaselineBscans);
  const float weights = along.weight + across.weight;
  if (weights == 0.0f) {
    return {nan, nan, nan, confidence, SurfaceState::none, FinishedKind::none};
  }
  return {(along.weight * along.value.ilm + across.weight * across.value.ilm) / weights,
          (along.weight * along.value.rpe + across.weight * across.value.rpe) / weights,
          (along.weight * along.value.bm + across.weight * across.value.bm) / weights,
          confidence,
          SurfaceState::bridged,
          FinishedKind::bridged};
}

}  // namespace ioct::gpu::segmentation::detail
