#include "ioct/gpu/instruments/tip_bscans.hpp"

#include <algorithm>
#include <cmath>

namespace ioct::gpu::instruments {
namespace {

// One B-scan through (x0, y0) um along the unit direction (ux, uy), into columns of `out`
// starting at `first_column`.
void cut(const Volume& v, double x0, double y0, double ux, double uy, double step_um, double sx,
         double sy, std::uint32_t first_column, TipBscans& out) {
  const std::uint32_t depth = v.depth();
  const auto half = static_cast<double>(out.width / 2);
  for (std::uint32_t c = 0; c < out.width; ++c) {
    const double s = (static_cast<double>(c) - half) * step_um;
    const double a = (x0 + s * ux) / sx;  // fractional A-scan, B-scan
    const double b = (y0 + s * uy) / sy;
    const double a0 = std::floor(a), b0 = std::floor(b);
    const double fa = a - a0, fb = b - b0;
    const auto ai = static_cast<std::int64_t>(a0), bi = static_cast<std::int64_t>(b0);
    // The four neighbours and their weights; one outside the field weighs nothing.
    const std::uint8_t* column[4] = {};
    double weight[4] = {};
    double total = 0.0;
    for (int k = 0; k < 4; ++k) {
      const std::int64_t ak = ai + (k & 1), bk = bi + (k >> 1);
      if (ak < 0 || bk < 0 || ak >= v.ascans() || bk >= v.bscans()) continue;
      column[k] =
          v.bscan(static_cast<std::uint32_t>(bk)).data() + static_cast<std::size_t>(ak) * depth;
      weight[k] = ((k & 1) != 0 ? fa : 1.0 - fa) * ((k >> 1) != 0 ? fb : 1.0 - fb);
      total += weight[k];
    }
    // Half a voxel or more outside the field: black, not a smear of the edge.
    const bool inside = a >= -0.5 && b >= -0.5 && a <= v.ascans() - 0.5 && b <= v.bscans() - 0.5;
    for (std::uint32_t d = 0; d < depth; ++d) {
      double sum = 0.0;
      if (inside && total > 0.0) {
        for (int k = 0; k < 4; ++k) {
          if (column[k] != nullptr) sum += weight[k] * column[k][d];
        }
        sum /= total;
      }
      out.pixels[std::size_t{d} * out.stride() + first_column + c] =
          static_cast<std::uint8_t>(std::lround(std::clamp(sum, 0.0, 255.0)));
    }
  }
}

}  // namespace

void cut_tip_bscans(const Volume& volume, const InstrumentTip& tip,
                    const segmentation::VolumeSampling& sampling, TipBscans& out,
                    double half_width_um) {
  const double sx = sampling.ascan_spacing_um, sy = sampling.bscan_spacing_um;
  const double step = sx;  // the finest lateral sampling the volume has
  out.width = 2 * static_cast<std::uint32_t>(std::max(1.0, std::round(half_width_um / step)));
  out.height = volume.depth();
  out.pixels.assign(std::size_t{out.stride()} * out.height, 0);
  if (volume.bscans() == 0 || volume.ascans() == 0 || out.height == 0) return;
  const double norm = std::hypot(tip.axis_x, tip.axis_y);
  const double ux = norm > 0.0 ? tip.axis_x / norm : 1.0, uy = norm > 0.0 ? tip.axis_y / norm : 0.0;
  cut(volume, tip.x_um, tip.y_um, ux, uy, step, sx, sy, 0, out);
  cut(volume, tip.x_um, tip.y_um, -uy, ux, step, sx, sy, out.width, out);
}

}  // namespace ioct::gpu::instruments
