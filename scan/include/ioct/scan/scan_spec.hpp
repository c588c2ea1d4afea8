// What a scan pattern should look like, before it is planned against the galvo's limits: the
// pattern kind, the field (size, offset, rotation), repeats and the recorded-but-inactive
// A-scans at each end of a line. The same keys make up the config file's [scan] table and the
// control channel's "scan" command.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "ioct/hal/digitizer_config.hpp"

namespace ioct::scan {

// The ring's scan_pattern_id of each kind. Raster keeps hal::ScanPatternKind::raster's value.
enum class ScanKind : std::uint32_t {
  raster = 1,         // unidirectional: each line left to right, the galvo flies back between
  bidirectional = 2,  // every other B-scan recorded right to left (kBscanReversed)
  crosshair = 3,      // a horizontal and a vertical line through the field's centre, alternating
  radial = 4,         // lines through the centre at evenly spaced angles over 180 degrees
};

std::string_view to_string(ScanKind kind) noexcept;
std::optional<ScanKind> scan_kind_from_string(std::string_view name) noexcept;

struct ScanSpec {
  ScanKind kind = ScanKind::raster;
  // B-scans in a row on the same line (averaging, OCT angiography); divides bscans_per_volume.
  std::uint32_t repeats = 1;
  // Half-size of the field along the pattern's own axes (before rotation), in scan units. The
  // default leaves the quintic turn-arounds room inside the scanner's range.
  static constexpr double kDefaultExtent = 0.95;
  double extent_x = kDefaultExtent;
  double extent_y = kDefaultExtent;
  double offset_x = 0.0;  // centre of the field, scan units
  double offset_y = 0.0;
  double rotation_deg = 0.0;  // counter-clockwise rotation of the whole pattern about its centre
  // Recorded A-scans at each end of a B-scan that lie outside the active range: the galvo is still
  // accelerating through them, which gives the turn-around more time.
  std::uint32_t inactive_ascans = 0;

  // Checks each key on its own range; throws ConfigError("scan.<key>"). The checks that need the
  // geometry and the galvo (divisibility, field, speed) are build_scan_pattern()'s.
  void validate() const;
  friend bool operator==(const ScanSpec&, const ScanSpec&) = default;
};

// The acquisition's timing that every pattern is planned for; fixed for the life of the ring.
struct ScanTiming {
  std::uint32_t records_per_bscan = 512;  // recorded sweeps (A-scans) per B-scan
  std::uint32_t flyback_sweeps = 26;      // unrecorded sweeps after each B-scan
  std::uint32_t bscans_per_volume = 128;  // B-scans per volume
  double sweep_rate_hz = 100'000.0;       // sweeps per second: one galvo sample per sweep

  // The timing of a digitizer's geometry, for volumes of `bscans_per_volume` B-scans.
  static ScanTiming of(const hal::DigitizerConfig& digitizer,
                       std::uint32_t bscans_per_volume) noexcept {
    return {digitizer.ascans_per_bscan, digitizer.flyback_sweeps, bscans_per_volume,
            digitizer.ascan_rate_hz};
  }

  std::uint64_t sweeps_per_bscan() const noexcept {
    return std::uint64_t{records_per_bscan} + flyback_sweeps;
  }
  std::uint64_t sweeps_per_volume() const noexcept {
    return sweeps_per_bscan() * bscans_per_volume;
  }
  friend bool operator==(const ScanTiming&, const ScanTiming&) = default;
};

// What the mirrors can do, per axis, in scan units ([-1, 1] spans the full field).
struct GalvoLimits {
  double max_velocity = 25'000.0;         // scan units per second
  double max_acceleration = 250'000'000;  // scan units per second squared

  // Throws ConfigError("galvo.max_velocity" / "galvo.max_acceleration").
  void validate() const;
  friend bool operator==(const GalvoLimits&, const GalvoLimits&) = default;
};

}  // namespace ioct::scan
