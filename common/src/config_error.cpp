#include "ioct/common/config_error.hpp"

#include <charconv>
#include <cmath>
#include <utility>

#include "ioct/common/input_file.hpp"

namespace ioct {

ConfigError::ConfigError(std::string key, std::string value, std::string_view allowed)
    : std::invalid_argument(key + " = " + value + ": " + std::string(allowed)),
      Error(ErrorCategory::config, std::move(key)),
      value_(std::move(value)) {}

std::string format_value(std::uint64_t value) {
  return std::to_string(value);
}

std::string format_value(std::int64_t value) {
  return std::to_string(value);
}

std::string format_text(std::string_view text) {
  return "\"" + quote_input(text, 60) + "\"";
}

std::string format_value(double value) {
  char text[64];
  const auto result = std::to_chars(text, text + sizeof(text), value);
  return std::string(text, result.ptr);
}

void require_integer_in_range(std::string_view key, std::uint64_t value, std::uint64_t lo,
                              std::uint64_t hi) {
  if (value < lo || value > hi) {
    throw ConfigError(std::string(key), format_value(value),
                      "must be in [" + format_value(lo) + ", " + format_value(hi) + "]");
  }
}

void require_real_in_range(std::string_view key, double value, double lo, double hi) {
  if (!std::isfinite(value) || value < lo || value > hi) {
    throw ConfigError(std::string(key), format_value(value),
                      "must be in [" + format_value(lo) + ", " + format_value(hi) + "]");
  }
}

}  // namespace ioct
