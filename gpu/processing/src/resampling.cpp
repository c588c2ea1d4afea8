#include "ioct/gpu/processing/resampling.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/common/input_file.hpp"

namespace ioct::gpu {
namespace {

constexpr const char* kKey = "resampling_coefficients";

// Cubic convolution weights of the samples at offsets -1, 0, 1, 2 from floor(x), f = x - floor(x).
void cubic_weights(double f, double w[4]) {
  const double f2 = f * f;
  const double f3 = f2 * f;
  w[0] = -0.5 * f3 + f2 - 0.5 * f;
  w[1] = 1.5 * f3 - 2.5 * f2 + 1.0;
  w[2] = -1.5 * f3 + 2.0 * f2 + 0.5 * f;
  w[3] = 0.5 * f3 - 0.5 * f2;
}

}  // namespace

std::string_view to_string(Interpolation interpolation) noexcept {
  switch (interpolation) {
    case Interpolation::none:
      return "none";
    case Interpolation::linear:
      return "linear";
    case Interpolation::cubic:
      return "cubic";
  }
  return "?";
}

Interpolation parse_interpolation(std::string_view text) {
  if (text == "none") return Interpolation::none;
  if (text == "linear") return Interpolation::linear;
  if (text == "cubic") return Interpolation::cubic;
  throw ConfigError("resampling", "'" + std::string(text) + "'", "must be none, linear or cubic");
}

ResamplingConfig choose_resampling(std::string_view interpolation,
                                   const std::vector<double>* calibration) {
  ResamplingConfig config;
  if (calibration != nullptr) config.coefficients = *calibration;
  config.interpolation = parse_interpolation(
      interpolation.empty() ? (calibration != nullptr ? "cubic" : "none") : interpolation);
  if (config.enabled() && calibration == nullptr) {
    throw ConfigError("resample", "'" + std::string(interpolation) + "'",
                      "needs a calibration (--resample-poly or --calibration-file)");
  }
  return config;
}

std::string format_coefficients(const std::vector<double>& coefficients) {
  std::string text = "[";
  for (std::size_t i = 0; i < coefficients.size(); ++i) {
    if (i > 0) text += ", ";
    text += format_value(coefficients[i]);
  }
  return text + "]";
}

std::vector<double> parse_coefficients(std::string_view text) {
  std::vector<double> values;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t comma = std::min(text.find(',', begin), text.size());
    std::string item(text.substr(begin, comma - begin));
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    double value = 0.0;
    const auto [end, error] = std::from_chars(item.data(), item.data() + item.size(), value);
    if (item.empty() || error != std::errc{} || end != item.data() + item.size()) {
      // The text may be a whole calibration file: shown printable and shortened.
      throw ConfigError(kKey, "'" + quote_input(text, 80) + "'",
                        "must be numbers separated by commas, e.g. 0,1,-0.02 (c0, c1, c2, ...)");
    }
    values.push_back(value);
    begin = comma + 1;
  }
  return values;
}

void ResamplingConfig::validate() const {
  if (interpolation != Interpolation::none && interpolation != Interpolation::linear &&
      interpolation != Interpolation::cubic) {
    throw ConfigError("resampling", std::to_string(static_cast<int>(interpolation)),
                      "must be none, linear or cubic");
  }
  if (coefficients.empty() || coefficients.size() > 8) {
    throw ConfigError(kKey, format_coefficients(coefficients),
                      "must have 1 to 8 coefficients (c0 + c1 t + ...; {0, 1} is the identity)");
  }
  for (std::size_t i = 0; i < coefficients.size(); ++i) {
    if (!std::isfinite(coefficients[i])) {
      throw ConfigError(std::string(kKey) + "[" + std::to_string(i) + "]",
                        format_value(coefficients[i]), "must be a finite number");
    }
  }
}

double calibration_position(const std::vector<double>& coefficients, std::uint32_t samples,
                            std::uint32_t j) noexcept {
  const double last = static_cast<double>(samples - 1);
  const double t = static_cast<double>(j) / last;
  double value = 0.0;
  for (std::size_t i = coefficients.size(); i-- > 0;) value = value * t + coefficients[i];
  return last * value;
}

void ResamplingConfig::validate_for(std::uint32_t samples) const {
  validate();
  if (!enabled()) return;
  const double last = static_cast<double>(samples - 1);
  constexpr double kSlack = 1e-6;  // rounding of a calibration that ends exactly on the sweep's
  double previous = 0.0;
  for (std::uint32_t j = 0; j < samples; ++j) {
    const double x = calibration_position(coefficients, samples, j);
    if (!(x >= -kSlack && x <= last + kSlack)) {
      throw ConfigError(kKey, format_coefficients(coefficients),
                        "leaves the sweep of " + std::to_string(samples) + " samples: x(" +
                            std::to_string(j) + ") = " + format_value(x) + " is outside [0, " +
                            format_value(last) + "]");
    }
    if (j > 0 && !(x > previous)) {
      throw ConfigError(kKey, format_coefficients(coefficients),
                        "is not monotonic: x(" + std::to_string(j) + ") = " + format_value(x) +
                            " does not increase from x(" + std::to_string(j - 1) +
                            ") = " + format_value(previous) + "; x must increase strictly");
    }
    previous = x;
  }
}

ResamplingTable make_resampling_table(const ResamplingConfig& config, std::uint32_t samples) {
  config.validate_for(samples);
  ResamplingTable table;
  if (!config.enabled()) return table;
  table.taps = config.interpolation == Interpolation::linear ? 2 : 4;
  table.first.resize(samples);
  table.weights.assign(std::size_t{samples} * table.taps, 0.0f);
  const auto last = static_cast<std::int64_t>(samples - 1);
  for (std::uint32_t j = 0; j < samples; ++j) {
    const double x = std::clamp(calibration_position(config.coefficients, samples, j), 0.0,
                                static_cast<double>(last));
    const auto base = static_cast<std::int64_t>(std::floor(x));
    const double f = x - static_cast<double>(base);
    double w[4] = {1.0 - f, f, 0.0, 0.0};
    std::int64_t offset = 0;  // index of w[0] relative to base
    if (table.taps == 4) {
      cubic_weights(f, w);
      offset = -1;
    }
    const std::int64_t first = std::clamp<std::int64_t>(
        base + offset, 0, last + 1 - static_cast<std::int64_t>(table.taps));
    double folded[4] = {0.0, 0.0, 0.0, 0.0};
    for (std::uint32_t t = 0; t < table.taps; ++t) {
      // Past either end the end sample stands in for the missing ones.
      const std::int64_t index = std::clamp<std::int64_t>(base + offset + t, 0, last);
      folded[index - first] += w[t];
    }
    table.first[j] = static_cast<std::uint32_t>(first);
    for (std::uint32_t t = 0; t < table.taps; ++t) {
      table.weights[std::size_t{j} * table.taps + t] = static_cast<float>(folded[t]);
    }
  }
  return table;
}

}  // namespace ioct::gpu
