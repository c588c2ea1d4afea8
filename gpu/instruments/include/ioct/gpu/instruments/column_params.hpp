// The detection's settings in px and u8 levels for one volume's sampling: what the CPU and CUDA
// column classification read.
#pragma once

#include <cstdint>

#include "ioct/gpu/instruments/instrument_config.hpp"

namespace ioct::gpu::instruments {

struct ColumnParams {
  std::int32_t depth = 0;
  std::int32_t skip_top = 0;
  std::int32_t object_margin = 0;
  std::int32_t dark_margin = 0;
  std::int32_t partial_reflex_margin = 0;
  std::int32_t gap = 1;          // px
  std::int32_t max_reflex = 1;   // px
  std::int32_t min_shadow = 1;   // px
  std::int32_t partial_gap = 1;  // px
};

// Throws ConfigError for a bad config or sampling.
ColumnParams make_column_params(const InstrumentConfig& config, const VolumeSampling& sampling,
                                std::uint32_t depth);

}  // namespace ioct::gpu::instruments
