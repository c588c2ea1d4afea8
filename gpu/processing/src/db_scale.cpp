#include "ioct/gpu/processing/db_scale.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

void DbScaleConfig::validate(std::string_view prefix) const {
  const std::string p = prefix.empty() ? std::string() : std::string(prefix) + ".";
  require_real_in_range(p + "db_min", db_min, -200.0, 300.0);
  require_real_in_range(p + "db_max", db_max, -200.0, 300.0);
  if (!(db_max - db_min >= 1.0)) {
    throw ConfigError(p + "db_max", format_value(db_max),
                      "must be at least 1 dB above db_min (" + format_value(db_min) + ")");
  }
}

DbToU8::DbToU8(const DbScaleConfig& config, double window_sum) {
  config.validate();
  if (!(window_sum > 0.0)) throw std::invalid_argument("DbToU8: window sum must be positive");
  const double range = config.db_max - config.db_min;
  norm_db_ = 20.0 * std::log10(2.0 / window_sum);
  db_min_ = config.db_min;
  // dB = 10 log10(power) + norm_db = 10 log10(2) log2(power) + norm_db
  gain_ = static_cast<float>(10.0 * std::log10(2.0) * 255.0 / range);
  offset_ = static_cast<float>((norm_db_ - db_min_) * 255.0 / range);
}

double DbToU8::db_of_power(double power) const {
  return 10.0 * std::log10(power) + norm_db_;
}

void DbToU8::map_row(const std::complex<float>* bins, std::uint8_t* out,
                     std::uint32_t count) const noexcept {
  // Locals and restrict: a u8 store may alias anything, members included, which would otherwise
  // force a reload of gain_ and offset_ per pixel and keep the loop scalar.
  const float gain = gain_;
  const float offset = offset_;
  const float* __restrict re_im = reinterpret_cast<const float*>(bins);
  std::uint8_t* __restrict pixels = out;
  for (std::size_t d = 0; d < count; ++d) {
    const float re = re_im[2 * d];
    const float im = re_im[2 * d + 1];
    pixels[d] = clamp_level(gain * log2_of(re * re + im * im) + offset);
  }
}

void DbToU8::map_power_row(const float* power, std::uint8_t* out,
                           std::uint32_t count) const noexcept {
  const float gain = gain_;
  const float offset = offset_;
  const float* __restrict in = power;
  std::uint8_t* __restrict pixels = out;
  for (std::size_t d = 0; d < count; ++d) pixels[d] = clamp_level(gain * log2_of(in[d]) + offset);
}

}  // namespace ioct::gpu
