#include "ioct/scan/scan_builder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <optional>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/scan/axis_move.hpp"
#include "ioct/scan/scan_infeasible.hpp"

namespace ioct::scan {
namespace {

struct Point {
  double x = 0.0;
  double y = 0.0;
};

// One B-scan's active line in scan units.
struct Line {
  Point start;
  Point end;
  bool reversed = false;
};

// i of n evenly over [-1, 1]; a single point sits at 0 (as hal::RasterScan places it).
double unit_ramp(std::uint32_t i, std::uint32_t n) {
  return n > 1 ? -1.0 + 2.0 * static_cast<double>(i) / static_cast<double>(n - 1) : 0.0;
}

// The lines of one volume in the pattern's own coordinates ([-1, 1] square), then mapped into
// the field.
std::vector<Line> lay_out_lines(const ScanSpec& spec, std::uint32_t bscans_per_volume) {
  const std::uint32_t lines = bscans_per_volume / spec.repeats;
  const double angle = spec.rotation_deg * std::numbers::pi / 180.0;
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  const auto to_field = [&](double u, double v) {
    const double x = spec.extent_x * u;
    const double y = spec.extent_y * v;
    return Point{spec.offset_x + c * x - s * y, spec.offset_y + s * x + c * y};
  };
  std::vector<Line> out(bscans_per_volume);
  for (std::uint32_t b = 0; b < bscans_per_volume; ++b) {
    const std::uint32_t line = b / spec.repeats;
    double u0 = -1.0, v0 = 0.0, u1 = 1.0, v1 = 0.0;
    bool reversed = false;
    switch (spec.kind) {
      case ScanKind::raster:
        v0 = v1 = unit_ramp(line, lines);
        break;
      case ScanKind::bidirectional:
        v0 = v1 = unit_ramp(line, lines);
        reversed = b % 2 == 1;
        break;
      case ScanKind::crosshair:
        if (line % 2 == 1) {  // the vertical line, bottom to top
          u0 = u1 = 0.0;
          v0 = -1.0;
          v1 = 1.0;
        }
        break;
      case ScanKind::radial: {
        const double phi = std::numbers::pi * static_cast<double>(line) / lines;
        u0 = -std::cos(phi);
        v0 = -std::sin(phi);
        u1 = std::cos(phi);
        v1 = std::sin(phi);
        break;
      }
    }
    if (reversed) {
      std::swap(u0, u1);
      std::swap(v0, v1);
    }
    out[b] = {to_field(u0, v0), to_field(u1, v1), reversed};
  }
  return out;
}

void check_fit(const ScanSpec& spec, const ScanTiming& timing) {
  require_integer_in_range("scan.bscans_per_volume", timing.bscans_per_volume, 1, 65536);
  require_integer_in_range("digitizer.ascans_per_bscan", timing.records_per_bscan, 1, 65536);
  require_real_in_range("digitizer.ascan_rate_hz", timing.sweep_rate_hz, 1.0, 10e6);
  if (timing.bscans_per_volume % spec.repeats != 0) {
    throw ConfigError("scan.repeats", format_value(std::uint64_t{spec.repeats}),
                      "must divide scan.bscans_per_volume = " +
                          format_value(std::uint64_t{timing.bscans_per_volume}));
  }
  const std::uint32_t lines = timing.bscans_per_volume / spec.repeats;
  if (spec.kind == ScanKind::crosshair && lines % 2 != 0) {
    throw ConfigError("scan.repeats", format_value(std::uint64_t{spec.repeats}),
                      "a crosshair volume holds whole pairs of lines: scan.bscans_per_volume / "
                      "scan.repeats = " +
                          format_value(std::uint64_t{lines}) + " must be even");
  }
  if (2ull * spec.inactive_ascans >= timing.records_per_bscan) {
    throw ConfigError("scan.inactive_ascans", format_value(std::uint64_t{spec.inactive_ascans}),
                      "must leave at least one active A-scan of digitizer.ascans_per_bscan = " +
                          format_value(std::uint64_t{timing.records_per_bscan}) + ": at most " +
                          format_value(std::uint64_t{(timing.records_per_bscan - 1) / 2}));
  }
}

// The worst violation found while planning, as a ratio of required to allowed (> 1 violates).
struct Violation {
  double ratio = 0.0;
  std::string limit;  // config key
  double required = 0.0;
  double allowed = 0.0;
  std::string where;  // "the flyback after B-scan 127 (volume end), y axis"
  bool flyback_helps = false;
};

void consider(std::optional<Violation>& worst, double required, double allowed, const char* limit,
              const std::string& where, bool flyback_helps) {
  const double ratio = required / allowed;
  if (ratio <= 1.0 + 1e-12) return;
  // Ties (a flyback that starts at the line's own speed) keep the first-named cause.
  if (!worst || ratio > worst->ratio * (1.0 + 1e-9)) {
    worst = Violation{ratio, limit, required, allowed, where, flyback_helps};
  }
}

std::string bscan_name(std::uint32_t b, std::uint32_t bscans_per_volume) {
  std::string text = "B-scan " + std::to_string(b);
  if (b + 1 == bscans_per_volume) text += " (volume end)";
  return text;
}

// Plans the volume with `flyback` sweeps after each B-scan. Fills `pattern` when given; returns
// the worst violation of the field or the limits, if any.
std::optional<Violation> plan(const ScanSpec& spec, const ScanTiming& timing,
                              const GalvoLimits& limits, std::uint32_t flyback,
                              ScanPattern* pattern) {
  const std::vector<Line> lines = lay_out_lines(spec, timing.bscans_per_volume);
  const std::uint32_t n = timing.records_per_bscan;
  const std::uint32_t m = spec.inactive_ascans;
  const std::uint32_t active = n - 2 * m;
  const std::uint64_t spb = std::uint64_t{n} + flyback;
  const std::uint64_t spv = spb * timing.bscans_per_volume;
  const double rate = timing.sweep_rate_hz;
  std::optional<Violation> worst;
  GalvoUsage usage;
  if (pattern != nullptr) {
    pattern->trajectory.assign(spv, hal::GalvoSample{});
    pattern->bscans.assign(timing.bscans_per_volume, BscanPlan{});
  }
  const auto put = [&](std::uint64_t sweep, double x, double y) {
    usage.peak_position = std::max({usage.peak_position, std::fabs(x), std::fabs(y)});
    if (pattern != nullptr) {
      pattern->trajectory[sweep % spv] = {static_cast<float>(x), static_cast<float>(y)};
    }
  };
  // Velocity of a line in scan units per sweep.
  const auto line_velocity = [&](const Line& line) {
    if (active < 2) return Point{};
    const double d = static_cast<double>(active - 1);
    return Point{(line.end.x - line.start.x) / d, (line.end.y - line.start.y) / d};
  };
  const auto line_point = [&](const Line& line, std::uint32_t i) {
    if (active < 2) return Point{(line.start.x + line.end.x) / 2, (line.start.y + line.end.y) / 2};
    const double f = static_cast<double>(i) / static_cast<double>(active - 1);
    return Point{line.start.x + f * (line.end.x - line.start.x),
                 line.start.y + f * (line.end.y - line.start.y)};
  };

  for (std::uint32_t b = 0; b < timing.bscans_per_volume; ++b) {
    const Line& line = lines[b];
    const std::uint64_t first_active = b * spb + m;
    for (std::uint32_t i = 0; i < active; ++i) {
      const Point p = line_point(line, i);
      put(first_active + i, p.x, p.y);
    }
    const Point v = line_velocity(line);
    const double line_speed = std::max(std::fabs(v.x), std::fabs(v.y)) * rate;
    usage.peak_velocity = std::max(usage.peak_velocity, line_speed);
    consider(worst, line_speed, limits.max_velocity, "galvo.max_velocity",
             bscan_name(b, timing.bscans_per_volume) + " itself (the line's constant speed)",
             false);
    if (pattern != nullptr) {
      const Point s = line_point(line, 0);
      const Point e = line_point(line, active - 1);
      pattern->bscans[b] = {line.reversed,
                            {static_cast<float>(s.x), static_cast<float>(s.y)},
                            {static_cast<float>(e.x), static_cast<float>(e.y)}};
    }

    // From this line's last active record to the next line's first (the next volume's first line
    // after the last): the inactive records, the flyback, and one sweep interval.
    const Line& next = lines[(b + 1) % timing.bscans_per_volume];
    const Point from = line_point(line, active - 1);
    const Point to = line_point(next, 0);
    const Point v_next = line_velocity(next);
    const double duration = static_cast<double>(flyback + 2 * m + 1);
    const double v_limit = limits.max_velocity / rate;               // per sweep
    const double a_limit = limits.max_acceleration / (rate * rate);  // per sweep squared
    const AxisMove tx = AxisMove::plan(from.x, v.x, to.x, v_next.x, duration, v_limit, a_limit);
    const AxisMove ty = AxisMove::plan(from.y, v.y, to.y, v_next.y, duration, v_limit, a_limit);
    const std::uint64_t last_active = first_active + active - 1;
    for (std::uint32_t t = 1; t < flyback + 2 * m + 1; ++t) {
      put(last_active + t, tx.position(t), ty.position(t));
    }
    const std::string where =
        (spec.kind == ScanKind::bidirectional ? "the turn-around after " : "the flyback after ") +
        bscan_name(b, timing.bscans_per_volume);
    const double vx = tx.peak_velocity() * rate;
    const double vy = ty.peak_velocity() * rate;
    const double ax = tx.peak_acceleration() * rate * rate;
    const double ay = ty.peak_acceleration() * rate * rate;
    usage.peak_velocity = std::max({usage.peak_velocity, vx, vy});
    usage.peak_acceleration = std::max({usage.peak_acceleration, ax, ay});
    consider(worst, vx, limits.max_velocity, "galvo.max_velocity", where + ", x axis", true);
    consider(worst, vy, limits.max_velocity, "galvo.max_velocity", where + ", y axis", true);
    consider(worst, ax, limits.max_acceleration, "galvo.max_acceleration", where + ", x axis",
             true);
    consider(worst, ay, limits.max_acceleration, "galvo.max_acceleration", where + ", y axis",
             true);
  }
  consider(worst, usage.peak_position, 1.0, "scan.field", "the commanded positions", false);
  if (pattern != nullptr) {
    pattern->usage = usage;
    pattern->active_begin = m;
    pattern->active_end = n - m;
  }
  return worst;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.4g", value);
  return text;
}

[[noreturn]] void refuse(const Violation& v, const ScanSpec& spec, const ScanTiming& timing,
                         const GalvoLimits& limits) {
  std::string message = "scan infeasible: " + v.where;
  if (v.limit == "scan.field") {
    message += " reach " + number(v.required) + ", beyond the field [-1, 1] by " +
               number(v.required - 1.0) +
               " scan units; reduce scan.extent_x/extent_y or scan.offset_x/offset_y";
    if (spec.kind == ScanKind::bidirectional) {
      message += " (a bidirectional turn-around overshoots the line's ends)";
    }
  } else {
    const char* unit = v.limit == "galvo.max_velocity" ? " units/s" : " units/s^2";
    message += " needs " + number(v.required) + unit + ", more than " + v.limit + " = " +
               number(v.allowed) + unit + " by " + number((v.ratio - 1.0) * 100.0) + "%";
    std::optional<std::uint32_t> enough;
    if (v.flyback_helps) {
      // More time makes the moves gentler: double until feasible, then bisect to the fewest.
      const auto feasible = [&](std::uint32_t f) {
        return !plan(spec, timing, limits, f, nullptr);
      };
      std::uint32_t low = timing.flyback_sweeps;  // infeasible
      std::uint32_t high = std::max<std::uint32_t>(1, low) * 2;
      while (high <= 65536 && !feasible(high)) {
        low = high;
        high *= 2;
      }
      if (high <= 65536) {
        while (high - low > 1) {
          const std::uint32_t mid = low + (high - low) / 2;
          (feasible(mid) ? high : low) = mid;
        }
        enough = high;
      }
    }
    if (enough) {
      message +=
          "; it needs at least " + std::to_string(*enough) +
          " flyback sweeps (digitizer.flyback_sweeps = " + std::to_string(timing.flyback_sweeps) +
          "), or a smaller field";
    } else {
      message += "; reduce the field (scan.extent_x/extent_y) or the A-scan rate";
    }
  }
  throw ScanInfeasible(v.limit, v.required, v.allowed, message);
}

}  // namespace

ScanPattern build_scan_pattern(const ScanSpec& spec, const ScanTiming& timing,
                               const GalvoLimits& limits) {
  spec.validate();
  limits.validate();
  check_fit(spec, timing);
  ScanPattern pattern;
  pattern.spec = spec;
  pattern.timing = timing;
  if (const std::optional<Violation> worst =
          plan(spec, timing, limits, timing.flyback_sweeps, &pattern)) {
    refuse(*worst, spec, timing, limits);
  }
  return pattern;
}

std::string ScanPattern::describe() const {
  char text[192];
  std::snprintf(text, sizeof(text),
                "%s, %u B-scans per volume (%u repeats), field %.3g x %.3g at (%.3g, %.3g), "
                "rotated %.3g deg, active A-scans [%u, %u)",
                std::string(to_string(spec.kind)).c_str(), timing.bscans_per_volume, spec.repeats,
                2 * spec.extent_x, 2 * spec.extent_y, spec.offset_x, spec.offset_y,
                spec.rotation_deg, active_begin, active_end);
  return text;
}

ScanPattern plan_raster(const hal::RasterScan& field, const hal::DigitizerConfig& digitizer,
                        ScanKind kind, const GalvoLimits& limits) {
  if (field.ascans_per_bscan != digitizer.ascans_per_bscan) {
    throw ConfigError("scan.ascans_per_bscan", format_value(std::uint64_t{field.ascans_per_bscan}),
                      "must be the digitizer's digitizer.ascans_per_bscan = " +
                          format_value(std::uint64_t{digitizer.ascans_per_bscan}));
  }
  ScanSpec spec;
  spec.kind = kind;
  spec.extent_x = field.extent_x;
  spec.extent_y = field.extent_y;
  spec.offset_x = field.center_x;
  spec.offset_y = field.center_y;
  return build_scan_pattern(spec, ScanTiming::of(digitizer, field.bscans_per_volume), limits);
}

}  // namespace ioct::scan
