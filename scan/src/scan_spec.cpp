#include "ioct/scan/scan_spec.hpp"

#include <array>
#include <utility>

#include "ioct/common/config_error.hpp"

namespace ioct::scan {
namespace {

constexpr std::array<std::pair<ScanKind, std::string_view>, 4> kKindNames{{
    {ScanKind::raster, "raster"},
    {ScanKind::bidirectional, "bidirectional"},
    {ScanKind::crosshair, "crosshair"},
    {ScanKind::radial, "radial"},
}};

}  // namespace

std::string_view to_string(ScanKind kind) noexcept {
  for (const auto& [k, name] : kKindNames) {
    if (k == kind) return name;
  }
  return "unknown";
}

std::optional<ScanKind> scan_kind_from_string(std::string_view name) noexcept {
  for (const auto& [k, n] : kKindNames) {
    if (n == name) return k;
  }
  return std::nullopt;
}

void ScanSpec::validate() const {
  if (to_string(kind) == "unknown") {
    throw ConfigError("scan.pattern", format_value(std::uint64_t{static_cast<std::uint32_t>(kind)}),
                      "must be one of raster, bidirectional, crosshair, radial");
  }
  require_integer_in_range("scan.repeats", repeats, 1, 65536);
  require_real_in_range("scan.extent_x", extent_x, 0.0, 1.0);
  require_real_in_range("scan.extent_y", extent_y, 0.0, 1.0);
  require_real_in_range("scan.offset_x", offset_x, -1.0, 1.0);
  require_real_in_range("scan.offset_y", offset_y, -1.0, 1.0);
  require_real_in_range("scan.rotation_deg", rotation_deg, -360.0, 360.0);
  require_integer_in_range("scan.inactive_ascans", inactive_ascans, 0, 32767);
}

void GalvoLimits::validate() const {
  require_real_in_range("galvo.max_velocity", max_velocity, 1e-3, 1e9);
  require_real_in_range("galvo.max_acceleration", max_acceleration, 1e-3, 1e15);
}

}  // namespace ioct::scan
