#include "ioct/gpu/segmentation/surfaces_csv.hpp"

#include <cmath>
#include <stdexcept>

namespace ioct::gpu::segmentation {

std::string_view to_string(SurfaceState state) noexcept {
  switch (state) {
    case SurfaceState::none:
      return "none";
    case SurfaceState::measured:
      return "measured";
    case SurfaceState::bridged:
      return "bridged";
  }
  return "unknown";
}

std::string_view to_string(BscanVerdict verdict) noexcept {
  switch (verdict) {
    case BscanVerdict::not_segmented:
      return "not_segmented";
    case BscanVerdict::retina:
      return "retina";
    case BscanVerdict::no_retina:
      return "no_retina";
  }
  return "unknown";
}

namespace {

// ",<value>" with 3 decimals, or "," for NaN.
void cell(std::FILE* stream, double value) {
  if (std::isfinite(value)) {
    std::fprintf(stream, ",%.3f", value);
  } else {
    std::fputc(',', stream);
  }
}

}  // namespace

void write_surfaces_csv(std::FILE* stream, const Surfaces& surfaces, double axial_um_per_px) {
  std::fputs("bscan,ascan,state,confidence,ilm_px,rpe_px,bm_px,ilm_um,rpe_um,bm_um\n", stream);
  for (std::uint32_t b = 0; b < surfaces.bscans; ++b) {
    for (std::uint32_t a = 0; a < surfaces.ascans; ++a) {
      const std::size_t k = surfaces.index(b, a);
      const std::string_view state = to_string(surfaces.state[k]);
      std::fprintf(stream, "%u,%u,%.*s,%.3f", b, a, static_cast<int>(state.size()), state.data(),
                   static_cast<double>(surfaces.confidence[k]));
      for (const float v : {surfaces.ilm[k], surfaces.rpe[k], surfaces.bm[k]}) cell(stream, v);
      for (const float v : {surfaces.ilm[k], surfaces.rpe[k], surfaces.bm[k]}) {
        cell(stream, static_cast<double>(v) * axial_um_per_px);
      }
      std::fputc('\n', stream);
    }
  }
  if (std::ferror(stream) != 0) throw std::runtime_error("writing the surfaces CSV failed");
}

}  // namespace ioct::gpu::segmentation
