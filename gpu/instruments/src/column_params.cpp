#include "ioct/gpu/instruments/column_params.hpp"

#include <algorithm>
#include <cmath>

namespace ioct::gpu::instruments {
namespace {

std::int32_t px_of(double um, const VolumeSampling& sampling) {
  return std::max<std::int32_t>(
      1, static_cast<std::int32_t>(std::lround(um / sampling.axial_um_per_px)));
}

}  // namespace

ColumnParams make_column_params(const InstrumentConfig& config, const VolumeSampling& sampling,
                                std::uint32_t depth) {
  config.validate();
  sampling.validate();
  ColumnParams p;
  p.depth = static_cast<std::int32_t>(depth);
  p.skip_top = static_cast<std::int32_t>(config.skip_top_px);
  p.object_margin = static_cast<std::int32_t>(config.object_margin);
  p.dark_margin = static_cast<std::int32_t>(config.dark_margin);
  p.partial_reflex_margin = static_cast<std::int32_t>(config.partial_reflex_margin);
  p.gap = px_of(config.gap_um, sampling);
  p.max_reflex = px_of(config.max_reflex_um, sampling);
  p.min_shadow = px_of(config.min_shadow_um, sampling);
  p.partial_gap = px_of(config.partial_gap_um, sampling);
  return p;
}

}  // namespace ioct::gpu::instruments
