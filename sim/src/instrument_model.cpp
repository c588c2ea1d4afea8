#include "ioct/sim/instrument_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {
namespace {

constexpr double kMediumIndex = 1.336;   // vitreous and aqueous
constexpr double kShaftLengthMm = 30.0;  // leaves the field in any pose
constexpr double kGauge23RadiusMm = 0.32;
constexpr double kGauge30RadiusMm = 0.155;
constexpr double kJawLengthMm = 1.2;
constexpr double kJawRadiusMm = 0.1;
constexpr double kPaddleLengthMm = 1.0;
constexpr double kPaddleHalfWidthMm = 0.35;
constexpr double kPaddleHalfThicknessMm = 0.06;
// Reflections (reflectivity-1 units) and the translucent paddle.
constexpr float kMetalReflectivity = 4.0f;
constexpr float kPaddleSurface = 0.8f;
constexpr float kPaddleScatter = 0.5f;
constexpr float kPaddleTransmission = 0.5f;
constexpr double kRayStartMm = -1000.0;

double deg(double degrees) noexcept {
  return degrees * std::numbers::pi / 180.0;
}

}  // namespace

std::string_view to_string(InstrumentKind kind) noexcept {
  switch (kind) {
    case InstrumentKind::forceps:
      return "forceps";
    case InstrumentKind::needle:
      return "needle";
    case InstrumentKind::scraper:
      return "scraper";
  }
  return "unknown";
}

void InstrumentConfig::validate(std::string_view prefix) const {
  const std::string p(prefix);
  if (kind != InstrumentKind::forceps && kind != InstrumentKind::needle &&
      kind != InstrumentKind::scraper) {
    throw ioct::ConfigError(p + ".kind", ioct::format_value(std::uint64_t(kind)),
                            "must be forceps, needle or scraper");
  }
  ioct::require_real_in_range(p + ".pose.tip_x", pose.tip_x, -3.0, 3.0);
  ioct::require_real_in_range(p + ".pose.tip_y", pose.tip_y, -3.0, 3.0);
  ioct::require_real_in_range(p + ".pose.tip_depth_fraction", pose.tip_depth_fraction, -1.0, 2.0);
  ioct::require_real_in_range(p + ".pose.yaw_deg", pose.yaw_deg, -360.0, 360.0);
  ioct::require_real_in_range(p + ".pose.pitch_deg", pose.pitch_deg, 0.0, 80.0);
  ioct::require_real_in_range(p + ".pose.jaw_opening_deg", pose.jaw_opening_deg, 0.0, 90.0);
  ioct::require_real_in_range(p + ".motion.velocity_x", motion.velocity_x, -100.0, 100.0);
  ioct::require_real_in_range(p + ".motion.velocity_y", motion.velocity_y, -100.0, 100.0);
  ioct::require_real_in_range(p + ".motion.velocity_depth", motion.velocity_depth, -100.0, 100.0);
  ioct::require_real_in_range(p + ".motion.tremor_x", motion.tremor_x, 0.0, 2.0);
  ioct::require_real_in_range(p + ".motion.tremor_y", motion.tremor_y, 0.0, 2.0);
  ioct::require_real_in_range(p + ".motion.tremor_depth", motion.tremor_depth, 0.0, 1.0);
  ioct::require_real_in_range(p + ".motion.tremor_hz", motion.tremor_hz, 0.0, 1000.0);
  ioct::require_real_in_range(p + ".motion.jaw_cycle_deg", motion.jaw_cycle_deg, 0.0, 90.0);
  ioct::require_real_in_range(p + ".motion.jaw_cycle_hz", motion.jaw_cycle_hz, 0.0, 100.0);
}

InstrumentModel::InstrumentModel(const InstrumentConfig& config, double field_half_width_mm,
                                 double axial_pixel_um, std::uint32_t depth_bins)
    : config_(config),
      field_mm_(field_half_width_mm),
      px_per_mm_(1e3 * kMediumIndex / axial_pixel_um),
      depth_bins_(depth_bins) {
  place(config.pose);
}

ToolPose InstrumentModel::pose_at(double seconds) const noexcept {
  const ToolMotion& m = config_.motion;
  const double tremor = std::sin(2.0 * std::numbers::pi * m.tremor_hz * seconds);
  ToolPose pose = config_.pose;
  pose.tip_x += static_cast<float>(m.velocity_x * seconds + m.tremor_x * tremor);
  pose.tip_y += static_cast<float>(m.velocity_y * seconds + m.tremor_y * tremor);
  pose.tip_depth_fraction +=
      static_cast<float>(m.velocity_depth * seconds + m.tremor_depth * tremor);
  pose.jaw_opening_deg += static_cast<float>(
      m.jaw_cycle_deg * 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * m.jaw_cycle_hz * seconds)));
  return pose;
}

ToolState InstrumentModel::state(const ToolPose& pose) const noexcept {
  return {pose.tip_x,   pose.tip_y,     static_cast<float>(pose.tip_depth_fraction * depth_bins_),
          pose.yaw_deg, pose.pitch_deg, pose.jaw_opening_deg};
}

ToolState InstrumentModel::tip_state(const ToolPose& pose) const noexcept {
  ToolState tip = state(pose);
  if (config_.kind != InstrumentKind::forceps || pose.jaw_opening_deg == 0.0f) return tip;
  // The jaws' ends lie jaw x (1 - cos(opening / 2)) back along the shaft's direction u.
  const double back = kJawLengthMm * (1.0 - std::cos(0.5 * deg(pose.jaw_opening_deg)));
  const double yaw = deg(pose.yaw_deg);
  const double pitch = deg(pose.pitch_deg);
  tip.tip_x += static_cast<float>(back * std::cos(pitch) * std::cos(yaw) / field_mm_);
  tip.tip_y += static_cast<float>(back * std::cos(pitch) * std::sin(yaw) / field_mm_);
  tip.tip_depth_px -= static_cast<float>(back * std::sin(pitch) * px_per_mm_);
  return tip;
}

void InstrumentModel::place(const ToolPose& pose) noexcept {
  const auto add = [](Vec3 p, Vec3 q, double s) {
    return Vec3{p.x + s * q.x, p.y + s * q.y, p.z + s * q.z};
  };
  const double yaw = deg(pose.yaw_deg);
  const double pitch = deg(pose.pitch_deg);
  // Depth grows downwards: a shaft that rises towards the viewer has a negative z component.
  const Vec3 u{std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), -std::sin(pitch)};
  const Vec3 w{-std::sin(yaw), std::cos(yaw), 0.0};
  const Vec3 n{u.y * w.z - u.z * w.y, u.z * w.x - u.x * w.z, u.x * w.y - u.y * w.x};
  const Vec3 tip{pose.tip_x * field_mm_, pose.tip_y * field_mm_,
                 pose.tip_depth_fraction * depth_bins_ / px_per_mm_};
  part_count_ = 0;
  const auto capsule = [&](Vec3 a, Vec3 b, double radius) {
    Part& part = parts_[part_count_++];
    part = Part{};
    part.a = a;
    part.b = b;
    part.radius = radius;
  };
  switch (config_.kind) {
    case InstrumentKind::needle:
      capsule(tip, add(tip, u, kShaftLengthMm), kGauge30RadiusMm);
      break;
    case InstrumentKind::forceps: {
      const Vec3 hinge = add(tip, u, kJawLengthMm);
      capsule(hinge, add(tip, u, kShaftLengthMm), kGauge23RadiusMm);
      const double half = 0.5 * deg(pose.jaw_opening_deg);
      for (const double side : {-1.0, 1.0}) {
        const Vec3 d{-u.x * std::cos(half) + side * w.x * std::sin(half),
                     -u.y * std::cos(half) + side * w.y * std::sin(half),
                     -u.z * std::cos(half) + side * w.z * std::sin(half)};
        capsule(hinge, add(hinge, d, kJawLengthMm), kJawRadiusMm);
      }
      break;
    }
    case InstrumentKind::scraper: {
      capsule(add(tip, u, kPaddleLengthMm), add(tip, u, kShaftLengthMm), kGauge23RadiusMm);
      Part& paddle = parts_[part_count_++];
      paddle = Part{};
      paddle.box = true;
      paddle.metal = false;
      paddle.a = add(tip, u, 0.5 * kPaddleLengthMm);
      paddle.axis_u = u;
      paddle.axis_w = w;
      paddle.axis_n = n;
      paddle.half = {0.5 * kPaddleLengthMm, kPaddleHalfWidthMm, kPaddleHalfThicknessMm};
      break;
    }
  }
  min_x_ = min_y_ = std::numeric_limits<double>::max();
  max_x_ = max_y_ = std::numeric_limits<double>::lowest();
  for (std::size_t i = 0; i < part_count_; ++i) {
    const Part& part = parts_[i];
    const double reach = part.box ? std::hypot(part.half.x, part.half.y, part.half.z) : part.radius;
    const Vec3 ends[2] = {part.a, part.box ? part.a : part.b};
    for (const Vec3& e : ends) {
      min_x_ = std::min(min_x_, e.x - reach);
      max_x_ = std::max(max_x_, e.x + reach);
      min_y_ = std::min(min_y_, e.y - reach);
      max_y_ = std::max(max_y_, e.y + reach);
    }
  }
}

ToolHit InstrumentModel::hit(hal::BeamPosition beam) const noexcept {
  ToolHit best;
  const double x = beam.x * field_mm_;
  const double y = beam.y * field_mm_;
  if (x < min_x_ || x > max_x_ || y < min_y_ || y > max_y_) return best;
  double best_z = std::numeric_limits<double>::max();
  const auto dot = [](Vec3 p, Vec3 q) { return p.x * q.x + p.y * q.y + p.z * q.z; };
  const Vec3 origin{x, y, kRayStartMm};
  const Vec3 down{0.0, 0.0, 1.0};
  for (std::size_t i = 0; i < part_count_; ++i) {
    const Part& part = parts_[i];
    if (!part.box) {
      // Ray against capsule (segment a-b, radius r): the body, then the end caps.
      const Vec3 ba{part.b.x - part.a.x, part.b.y - part.a.y, part.b.z - part.a.z};
      const Vec3 oa{origin.x - part.a.x, origin.y - part.a.y, origin.z - part.a.z};
      const double baba = dot(ba, ba);
      const double bard = dot(ba, down);
      const double baoa = dot(ba, oa);
      const double rdoa = dot(down, oa);
      const double oaoa = dot(oa, oa);
      const double r2 = part.radius * part.radius;
      const double a = baba - bard * bard;
      const double b = baba * rdoa - baoa * bard;
      const double c = baba * oaoa - baoa * baoa - r2 * baba;
      double h = b * b - a * c;
      double t = -1.0;
      Vec3 normal{0.0, 0.0, -1.0};
      if (h >= 0.0 && a > 0.0) {
        const double tb = (-b - std::sqrt(h)) / a;
        const double along = baoa + tb * bard;
        if (along > 0.0 && along < baba) {
          t = tb;
          const Vec3 p{origin.x, origin.y, origin.z + t};
          const double s = along / baba;
          const Vec3 axis{part.a.x + s * ba.x, part.a.y + s * ba.y, part.a.z + s * ba.z};
          normal = {(p.x - axis.x) / part.radius, (p.y - axis.y) / part.radius,
                    (p.z - axis.z) / part.radius};
        } else {
          const Vec3 cap = along <= 0.0 ? part.a : part.b;
          const Vec3 oc{origin.x - cap.x, origin.y - cap.y, origin.z - cap.z};
          const double bc = dot(down, oc);
          const double cc = dot(oc, oc) - r2;
          h = bc * bc - cc;
          if (h > 0.0) {
            t = -bc - std::sqrt(h);
            const Vec3 p{origin.x, origin.y, origin.z + t};
            normal = {(p.x - cap.x) / part.radius, (p.y - cap.y) / part.radius,
                      (p.z - cap.z) / part.radius};
          }
        }
      }
      if (t < 0.0) continue;
      const double z = origin.z + t;
      if (z >= best_z) continue;
      best_z = z;
      // Polished metal: bright where the surface faces the beam, dim on the flanks.
      const double facing = std::abs(normal.z);
      best.hit = true;
      best.entry_px = static_cast<float>(z * px_per_mm_);
      best.exit_px = best.entry_px;
      best.amplitude = kMetalReflectivity * static_cast<float>(0.15 + 0.85 * std::pow(facing, 4.0));
      best.back_amplitude = 0.0f;
      best.interior_scatter = 0.0f;
      best.transmission = 0.0f;
    } else {
      // Ray against an oriented box: slabs along its three axes.
      const Vec3 d{origin.x - part.a.x, origin.y - part.a.y, origin.z - part.a.z};
      const Vec3 axes[3] = {part.axis_u, part.axis_w, part.axis_n};
      const double half[3] = {part.half.x, part.half.y, part.half.z};
      double enter = std::numeric_limits<double>::lowest();
      double leave = std::numeric_limits<double>::max();
      double facing = 0.0;
      bool miss = false;
      for (int k = 0; k < 3 && !miss; ++k) {
        const double o = dot(d, axes[k]);
        const double dir = dot(down, axes[k]);
        if (std::abs(dir) < 1e-12) {
          miss = std::abs(o) > half[k];
          continue;
        }
        double t0 = (-half[k] - o) / dir;
        double t1 = (half[k] - o) / dir;
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > enter) {
          enter = t0;
          facing = std::abs(dir);
        }
        leave = std::min(leave, t1);
        miss = enter > leave;
      }
      if (miss || leave < 0.0) continue;
      const double z = origin.z + enter;
      if (z >= best_z) continue;
      best_z = z;
      best.hit = true;
      best.entry_px = static_cast<float>(z * px_per_mm_);
      best.exit_px = static_cast<float>((origin.z + leave) * px_per_mm_);
      best.amplitude = kPaddleSurface * static_cast<float>(0.3 + 0.7 * facing * facing);
      best.back_amplitude = 0.5f * best.amplitude;
      best.interior_scatter = kPaddleScatter;
      best.transmission = kPaddleTransmission;
    }
  }
  return best;
}

}  // namespace ioct::sim
