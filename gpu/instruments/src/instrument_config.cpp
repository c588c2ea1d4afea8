#include "ioct/gpu/instruments/instrument_config.hpp"

#include "ioct/common/config_error.hpp"

namespace ioct::gpu::instruments {

void InstrumentConfig::validate() const {
  require_integer_in_range("instruments.skip_top_px", skip_top_px, 0, 1024);
  require_integer_in_range("instruments.object_margin", object_margin, 1, 254);
  require_integer_in_range("instruments.dark_margin", dark_margin, 0, 253);
  if (dark_margin >= object_margin) {
    throw ConfigError(
        "instruments.dark_margin", format_value(std::uint64_t{dark_margin}),
        "must be below instruments.object_margin (" + std::to_string(object_margin) + ")");
  }
  require_real_in_range("instruments.gap_um", gap_um, 0.1, 2000.0);
  require_real_in_range("instruments.max_reflex_um", max_reflex_um, 1.0, 5000.0);
  require_real_in_range("instruments.min_shadow_um", min_shadow_um, 1.0, 5000.0);
  require_integer_in_range("instruments.partial_reflex_margin", partial_reflex_margin, 1, 254);
  require_real_in_range("instruments.partial_gap_um", partial_gap_um, 1.0, 5000.0);
  require_integer_in_range("instruments.min_ascans", min_ascans, 1, 1u << 20);
  require_real_in_range("instruments.medium_group_index", medium_group_index, 1.0, 2.0);
  require_real_in_range("instruments.warn_rpe_um", warn_rpe_um, 0.0, 10000.0);
}

}  // namespace ioct::gpu::instruments
