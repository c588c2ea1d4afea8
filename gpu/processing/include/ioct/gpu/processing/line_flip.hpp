// Bidirectional scanning records every other B-scan right to left. The flip happens where a
// processed A-scan is stored: record r of a reversed B-scan goes to column width - 1 - r, so the
// image is always left to right and no separate pass over the pixels is needed.
#pragma once

#include <cstdint>

namespace ioct::gpu {

constexpr std::uint32_t placed_column(std::uint32_t record, std::uint32_t width,
                                      bool reversed) noexcept {
  return reversed ? width - 1 - record : record;
}

}  // namespace ioct::gpu
