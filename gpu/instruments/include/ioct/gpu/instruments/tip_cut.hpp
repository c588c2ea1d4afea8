// The arithmetic of the tip's B-scan pair (tip_bscans.hpp), the same on the host and the device
// (IOCT_HD), so the CPU and the CUDA cut give the same pixels: where each column of the pair lies
// in the volume, and a pixel of it from the four A-scans around that point.
#pragma once

#include <cmath>
#include <cstdint>

#include "ioct/gpu/cuda/host_device_function.hpp"

namespace ioct::gpu::instruments {

// The pair through one tip: `width` columns each, centred on the tip (x0, y0 um), along (ux, uy)
// and across (-uy, ux), `step_um` apart; sx, sy: the volume's A-scan and B-scan spacing.
struct TipCut {
  std::uint32_t width = 0;
  double x0 = 0.0, y0 = 0.0, ux = 1.0, uy = 0.0;
  double step_um = 1.0, sx = 1.0, sy = 1.0;
};

// One column of the pair: its four neighbouring A-scans (offsets of their first px in the
// volume, -1 outside the field) and bilinear weights; black when half a voxel or more outside.
struct TipColumn {
  long long offset[4] = {-1, -1, -1, -1};
  double weight[4] = {};
  double total = 0.0;
  bool inside = false;
};

// Column `c` of the pair ([0, width) along, [width, 2 width) across) in a volume
// [bscan][ascan][depth].
IOCT_HD TipColumn tip_column(const TipCut& cut, std::uint32_t c, std::uint32_t bscans,
                             std::uint32_t ascans, std::uint32_t depth) {
  const bool across = c >= cut.width;
  const double ux = across ? -cut.uy : cut.ux, uy = across ? cut.ux : cut.uy;
  const double half = static_cast<double>(cut.width / 2);
  const double s = (static_cast<double>(across ? c - cut.width : c) - half) * cut.step_um;
  const double a = (cut.x0 + s * ux) / cut.sx;  // fractional A-scan, B-scan
  const double b = (cut.y0 + s * uy) / cut.sy;
  const double a0 = floor(a), b0 = floor(b);
  const double fa = a - a0, fb = b - b0;
  const auto ai = static_cast<long long>(a0), bi = static_cast<long long>(b0);
  TipColumn col;
  for (int k = 0; k < 4; ++k) {
    const long long ak = ai + (k & 1), bk = bi + (k >> 1);
    if (ak < 0 || bk < 0 || ak >= ascans || bk >= bscans) continue;
    col.offset[k] = (bk * ascans + ak) * static_cast<long long>(depth);
    col.weight[k] = ((k & 1) != 0 ? fa : 1.0 - fa) * ((k >> 1) != 0 ? fb : 1.0 - fb);
    col.total += col.weight[k];
  }
  col.inside = a >= -0.5 && b >= -0.5 && a <= ascans - 0.5 && b <= bscans - 0.5;
  return col;
}

// Px `d` of a column, rounded to the nearest level.
IOCT_HD std::uint8_t tip_pixel(const TipColumn& col, const std::uint8_t* volume, std::uint32_t d) {
  if (!col.inside || col.total <= 0.0) return 0;
  double sum = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (col.offset[k] >= 0) sum += col.weight[k] * volume[col.offset[k] + d];
  }
  sum /= col.total;
  sum = sum < 0.0 ? 0.0 : (sum > 255.0 ? 255.0 : sum);
  return static_cast<std::uint8_t>(floor(sum + 0.5));
}

}  // namespace ioct::gpu::instruments
