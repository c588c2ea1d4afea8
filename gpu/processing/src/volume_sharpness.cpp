#include "ioct/gpu/processing/volume_sharpness.hpp"

#include <array>
#include <cmath>
#include <stdexcept>

namespace ioct::gpu {

double volume_sharpness(const ProcessedGroup& group, const DbScaleConfig& scale,
                        std::span<const std::uint8_t> kept_rows) {
  if (kept_rows.size() != group.depth) {
    throw std::invalid_argument("volume_sharpness: " + std::to_string(kept_rows.size()) +
                                " row flags for a depth of " + std::to_string(group.depth));
  }
  std::array<double, 256> intensity{};
  for (std::uint32_t level = 0; level < 256; ++level) {
    const double db = scale.db_min + (scale.db_max - scale.db_min) * level / 255.0;
    intensity[level] = std::pow(10.0, db / 10.0);
  }
  const std::uint64_t ascans = std::uint64_t{group.bscan_count} * group.ascans;
  if (ascans == 0) return 0.0;
  double total = 0.0;
  for (std::uint64_t a = 0; a < ascans; ++a) {
    const std::uint8_t* column = group.pixels.data() + a * group.depth;
    double sum = 0.0;
    double sum_squares = 0.0;
    for (std::uint32_t d = 0; d < group.depth; ++d) {
      if (kept_rows[d] == 0) continue;
      const double i = intensity[column[d]];
      sum += i;
      sum_squares += i * i;
    }
    if (sum > 0.0) total += sum_squares / (sum * sum);
  }
  return total / static_cast<double>(ascans);
}

}  // namespace ioct::gpu
