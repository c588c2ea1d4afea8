#include "ioct/gpu/processing/spectral_window.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

std::string_view to_string(WindowKind kind) noexcept {
  switch (kind) {
    case WindowKind::hann:
      return "hann";
    case WindowKind::rectangular:
      return "rectangular";
  }
  return "?";
}

WindowKind parse_window_kind(std::string_view text) {
  if (text == "hann") return WindowKind::hann;
  if (text == "rectangular" || text == "none") return WindowKind::rectangular;
  throw ConfigError("window", "'" + std::string(text) + "'", "must be hann or rectangular");
}

void WindowConfig::validate() const {
  if (kind != WindowKind::hann && kind != WindowKind::rectangular) {
    throw ConfigError("window", std::to_string(static_cast<int>(kind)),
                      "must be hann or rectangular");
  }
}

std::vector<float> make_window(WindowKind kind, std::uint32_t samples) {
  if (samples < 2) {
    throw std::invalid_argument("window: " + std::to_string(samples) +
                                " samples, at least 2 are needed");
  }
  std::vector<float> window(samples, 1.0f);
  if (kind == WindowKind::hann) {
    const double step = 2.0 * std::numbers::pi / (samples - 1);
    for (std::uint32_t n = 0; n < samples; ++n) {
      window[n] = static_cast<float>(0.5 * (1.0 - std::cos(step * n)));
    }
  }
  return window;
}

}  // namespace ioct::gpu
