// Bruch's membrane beneath a lifted RPE, per B-scan, written once for the CPU and the CUDA
// kernels: the per-A-scan arithmetic is here; each side loops over the A-scans of a B-scan.
//
// The fit's BM is the outer side of the RPE band (fit_column). Where the RPE lies on Bruch's
// membrane that is the membrane. Where the RPE is lifted off it (drusen, a small detachment) the
// band follows the lifted RPE while the membrane stays beneath, smooth. As in drusen segmentation
// (Chiu, Farsiu et al.: a smooth baseline through the RPE floor, the parts lifted above it taken
// out), per B-scan, on the finished BM:
//   1. the median along the B-scan over kMedianUm either side (a single fit's outliers out);
//   2. its floor, by peak clipping (SNIP): for p = 1 .. reach (kClipUm), every A-scan becomes the
//      deeper of itself and the mean of the A-scans p to either side. What rises above its
//      surroundings (a hump) is cut down to the chord beneath it, the cuts adding up over the
//      passes; straight and bowl-shaped stretches (the chord above them) stay as they are;
//   3. where the smoothed BM lies more than kLiftUm above its floor, the BM is the floor
//      (inferred beneath the lifted RPE); elsewhere the finished BM as it was.
// The RPE surface stays the RPE.
#pragma once

#include <cmath>

#include "ioct/gpu/cuda/host_device_function.hpp"

namespace ioct::gpu::segmentation::detail {

// The median's reach either side: a fit's outliers (the band's outer side found in the choroid
// for a few A-scans) are narrower than this.
inline constexpr double kMedianUm = 72.0;
inline constexpr int kMaxMedianReach = 8;
// The clipping's reach: humps are cut down over the passes from both their sides, so humps
// several times as wide go (the Spectralis scan's drusen, about 0.6 mm); wider ones would take the
// retina's own curvature (a B-scan bending where it runs out of the image) with them.
inline constexpr double kClipUm = 216.0;
inline constexpr int kMaxClipReach = 64;
// How far above its floor the smoothed BM must lie to count as lifted: above the fit's noise.
inline constexpr double kLiftUm = 12.0;

struct MembraneSettings {
  int median_reach = 1;  // A-scans either side
  int clip_reach = 1;    // passes, the last reaching this many A-scans either side
  float lift_px = 3.0f;
};

// The settings in A-scans and depth px of a sampling.
inline MembraneSettings membrane_settings(double ascan_spacing_um, double axial_um_per_px) {
  const auto ascans = [&](double um, int most) {
    const int n = static_cast<int>(std::lround(um / ascan_spacing_um));
    return n < 1 ? 1 : (n > most ? most : n);
  };
  return {ascans(kMedianUm, kMaxMedianReach), ascans(kClipUm, kMaxClipReach),
          static_cast<float>(kLiftUm / axial_um_per_px)};
}

// Step 1 at A-scan a: the median of the finite values within `reach` A-scans either side (the
// mean of the middle two for an even count); NaN when there are none. The window is sorted by a
// fixed network in registers, the missing values last as +infinity (no per-element branches, no
// indexed local array on the GPU).
IOCT_HD float bm_median_at(const float* bm, int ascans, int a, int reach) {
  constexpr int kSlots = 2 * kMaxMedianReach + 1;
  float v[kSlots];
  int n = 0;
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = 0; i < kSlots; ++i) {
    const int k = a - reach + i;
    const float value = i <= 2 * reach && k >= 0 && k < ascans ? bm[k] : NAN;
    const bool finite = value == value;
    v[i] = finite ? value : INFINITY;
    n += finite ? 1 : 0;
  }
  if (n == 0) return NAN;
    // Odd-even transposition: kSlots rounds sort kSlots values.
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int round = 0; round < kSlots; ++round) {
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (int i = round & 1; i + 1 < kSlots; i += 2) {
      const float low = v[i] < v[i + 1] ? v[i] : v[i + 1];
      const float high = v[i] < v[i + 1] ? v[i + 1] : v[i];
      v[i] = low;
      v[i + 1] = high;
    }
  }
  float below = 0.0f;  // the (n - 1) / 2-th and n / 2-th smallest
  float above = 0.0f;
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = 0; i < kSlots; ++i) {
    below = i == (n - 1) / 2 ? v[i] : below;
    above = i == n / 2 ? v[i] : above;
  }
  return (n & 1) != 0 ? above : 0.5f * (below + above);
}

// Step 2, one pass of reach p at A-scan a: the deeper of z[a] and the mean of z[a - p] and
// z[a + p]; z[a] where either lies outside the B-scan or a value is NaN.
IOCT_HD float clipped_at(const float* z, int ascans, int a, int p) {
  const float here = z[a];
  if (a - p < 0 || a + p >= ascans) return here;
  const float chord = 0.5f * (z[a - p] + z[a + p]);
  return chord > here ? chord : here;  // false for NaN: here
}

// Step 3: the membrane at an A-scan from its finished BM, the smoothed BM and its floor; an A-scan
// without a BM (NaN: nothing to finish it from) stays without one.
IOCT_HD float membrane_at(float bm, float smoothed, float floor, float lift_px) {
  return bm == bm && smoothed < floor - lift_px ? floor : bm;
}

// Steps 1-3 over one B-scan on the host (the CPU segmenter's loop; the CUDA kernel runs the same
// functions a thread per A-scan between barriers): `bm` from `finished_bm`, both `ascans` long.
// `smoothed`, `floor` and `next_floor` are scratch of `ascans` floats; `smoothed` and `floor` hold
// the smoothed BM and its floor afterwards.
inline void membrane_of_bscan(const float* finished_bm, int ascans, const MembraneSettings& m,
                              float* bm, float* smoothed, float* floor, float* next_floor) {
  for (int a = 0; a < ascans; ++a) {
    smoothed[a] = bm_median_at(finished_bm, ascans, a, m.median_reach);
    floor[a] = smoothed[a];
  }
  for (int p = 1; p <= m.clip_reach; ++p) {
    for (int a = 0; a < ascans; ++a) next_floor[a] = clipped_at(floor, ascans, a, p);
    for (int a = 0; a < ascans; ++a) floor[a] = next_floor[a];
  }
  for (int a = 0; a < ascans; ++a) {
    bm[a] = membrane_at(finished_bm[a], smoothed[a], floor[a], m.lift_px);
  }
}

}  // namespace ioct::gpu::segmentation::detail
