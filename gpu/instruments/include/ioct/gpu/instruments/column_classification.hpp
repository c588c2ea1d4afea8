// One A-scan at a time: is an instrument above the tissue here, and where is its reflex? The same
// integer arithmetic on the host and on the device (IOCT_HD), so both backends agree bit for bit.
//
// From the top (below skip_top), the first px at least object_margin above the B-scan's floor
// starts an object; the first object ends at the first run of `gap` px at most dark_margin above
// the floor. Then:
//   shadow   from the object's top to the column's last bright px is at most max_reflex deep,
//            and beneath that px, down to the bottom (at least min_shadow), the mean is at most
//            half the dark margin above the floor: a metal tool (a bright reflex, and the signal
//            beneath falls to the noise floor), also inside the retina with tissue above it;
//   partial  the first object is at most max_reflex deep, its peak at least
//            partial_reflex_margin above the floor, and more signal follows below a gap of at
//            least partial_gap px whose mean is at most half the dark margin above the floor: a
//            translucent tool (the scraper's paddle) above the tissue it half shadows;
//   clear    anything else (tissue from the top, nothing at all, an object too deep to be a tool).
// A metal tool's reflex is its last peak (from the last bright px upwards while the px rise),
// refined by a parabola through it and its neighbours; a translucent tool's is the middle of the
// object, and its front surface the object's top.
#pragma once

#include <cstdint>

#include "ioct/gpu/cuda/host_device_function.hpp"
#include "ioct/gpu/instruments/column_params.hpp"

namespace ioct::gpu::instruments {

enum class ColumnKind : std::uint8_t { clear = 0, shadow = 1, partial = 2 };

struct ColumnFinding {
  ColumnKind kind = ColumnKind::clear;
  float reflex_px = 0.0f;  // NaN-free: 0 for clear
  // A translucent tool's front surface (the object's first px): with its middle (reflex_px),
  // half its height in this A-scan, which places its leading edge (tip_finder.hpp). 0 unless
  // partial.
  float front_px = 0.0f;
};

IOCT_HD float parabola_peak(int at, int v0, int v1, int v2) {
  const int curvature = v0 - 2 * v1 + v2;
  if (curvature >= 0) return static_cast<float>(at);
  return static_cast<float>(at) +
         0.5f * static_cast<float>(v0 - v2) / static_cast<float>(curvature);
}

IOCT_HD ColumnFinding classify_column(const std::uint8_t* column, const ColumnParams& p,
                                      int floor_level) {
  ColumnFinding out;
  const int object_level = floor_level + p.object_margin;
  const int dark_level = floor_level + p.dark_margin;
  int top = -1;
  for (int z = p.skip_top; z < p.depth; ++z) {
    if (column[z] >= object_level) {
      top = z;
      break;
    }
  }
  if (top < 0) return out;
  // The first object's end: the first px of a run of `gap` dark px.
  int end = -1;
  int dark_run = 0;
  for (int z = top; z < p.depth; ++z) {
    if (column[z] > dark_level) {
      dark_run = 0;
    } else if (++dark_run == p.gap) {
      end = z - p.gap + 1;
      break;
    }
  }
  // A metal tool: bright px from the top of the object (the tool's reflex, or tissue above a tool
  // inside the retina, with dark bands of its own) down to the column's last bright px, at most
  // max_reflex deep, and beneath it nothing down to the bottom (at least min_shadow): its mean
  // at most half the dark margin above the floor. The reflex is the last peak (climbing up from
  // the last bright px while the px rise).
  int last = p.depth - 1;
  while (last > top && column[last] < object_level) --last;
  if (p.depth - 1 - last >= p.min_shadow && last - top <= p.max_reflex) {
    int below_sum = 0;
    for (int z = last + 1; z < p.depth; ++z) below_sum += column[z] - floor_level;
    if (2 * below_sum <= p.dark_margin * (p.depth - 1 - last)) {
      int peak = last;
      while (peak > top && column[peak - 1] > column[peak]) --peak;
      const int v0 = peak > 0 ? column[peak - 1] : column[peak];
      const int v2 = peak + 1 < p.depth ? column[peak + 1] : column[peak];
      out.kind = ColumnKind::shadow;
      out.reflex_px = parabola_peak(peak, v0, column[peak], v2);
      return out;
    }
  }
  // A translucent tool floats in the vitreous: an object at most max_reflex deep whose peak is
  // partial_reflex_margin above the floor, then a long gap, nearly empty (inside the retina,
  // speckle leaves short dark runs between brighter px), then more signal.
  if (end < 0 || end - top > p.max_reflex) return out;
  int next = -1;
  for (int z = end; z < p.depth; ++z) {
    if (column[z] >= object_level) {
      next = z;
      break;
    }
  }
  if (next < 0 || next - end < p.partial_gap) return out;
  int peak = top;
  for (int z = top; z < end; ++z) {
    if (column[z] > column[peak]) peak = z;
  }
  if (column[peak] < floor_level + p.partial_reflex_margin) return out;
  int gap_sum = 0;
  for (int z = end; z < next; ++z) gap_sum += column[z] - floor_level;
  if (2 * gap_sum > p.dark_margin * (next - end)) return out;
  out.kind = ColumnKind::partial;
  // Its front and back surfaces bound it: its middle is its axis.
  out.reflex_px = 0.5f * static_cast<float>(top + end - 1);
  out.front_px = static_cast<float>(top);
  return out;
}

// The noise floor of one B-scan: the median of its px, from a histogram of 256 bins (most of a
// B-scan is vitreous and the dark below the tissue).
IOCT_HD int median_of_histogram(const std::uint32_t* histogram, std::uint64_t count) {
  const std::uint64_t half = (count + 1) / 2;
  std::uint64_t seen = 0;
  for (int level = 0; level < 256; ++level) {
    seen += histogram[level];
    if (seen >= half) return level;
  }
  return 255;
}

}  // namespace ioct::gpu::instruments
