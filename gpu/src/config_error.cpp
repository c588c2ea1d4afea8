#include "ioct/gpu/config_error.hpp"

#include <charconv>
#include <cmath>

namespace ioct::gpu {

std::string format_number(double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

void require_in_range(const std::string& key, double value, double lo, double hi) {
  if (!(value >= lo && value <= hi)) {  // also rejects NaN
    throw ConfigError(key, format_number(value),
                      "must be in [" + format_number(lo) + ", " + format_number(hi) + "]");
  }
}

}  // namespace ioct::gpu
