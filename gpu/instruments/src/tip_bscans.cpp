#include "ioct/gpu/instruments/tip_bscans.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cuda_tip_bscans.hpp"
#include "ioct/gpu/instruments/tip_cut.hpp"

namespace ioct::gpu::instruments {

void cut_tip_bscans(VolumeRef volume, const InstrumentTip& tip,
                    const segmentation::VolumeSampling& sampling, TipBscans& out,
                    double half_width_um) {
  const VolumeDims& dims = volume.dims();
  TipCut cut;
  cut.sx = sampling.ascan_spacing_um;
  cut.sy = sampling.bscan_spacing_um;
  cut.step_um = cut.sx;  // the finest lateral sampling the volume has
  cut.width =
      2 * static_cast<std::uint32_t>(std::max(1.0, std::round(half_width_um / cut.step_um)));
  cut.x0 = tip.x_um;
  cut.y0 = tip.y_um;
  const double norm = std::hypot(tip.axis_x, tip.axis_y);
  cut.ux = norm > 0.0 ? tip.axis_x / norm : 1.0;
  cut.uy = norm > 0.0 ? tip.axis_y / norm : 0.0;
  out.width = cut.width;
  out.height = dims.depth;
  out.pixels.assign(std::size_t{out.stride()} * out.height, 0);
  if (dims.bscans == 0 || dims.ascans == 0 || out.height == 0) return;
  if (volume.is_device()) {
#if IOCT_INSTRUMENTS_HAVE_CUDA
    cut_tip_bscans_on_device(volume, cut, out);
    return;
#else
    throw std::logic_error("instruments: a device volume in a build without CUDA");
#endif
  }
  const std::uint8_t* pixels = volume.host().pixels().data();
  for (std::uint32_t c = 0; c < out.stride(); ++c) {
    const TipColumn col = tip_column(cut, c, dims.bscans, dims.ascans, dims.depth);
    for (std::uint32_t d = 0; d < dims.depth; ++d) {
      out.pixels[std::size_t{d} * out.stride() + c] = tip_pixel(col, pixels, d);
    }
  }
}

}  // namespace ioct::gpu::instruments
