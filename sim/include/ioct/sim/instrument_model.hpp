// Surgical instruments above (or in) the tissue: forceps, a needle, a membrane scraper.
//
// Each is built from capsules (a segment with a radius: shafts, jaws, the needle) and boxes (the
// scraper's flat silicone paddle). Metal reflects strongly where its surface faces the beam and
// lets nothing through: everything below it is in its shadow. The paddle is translucent: a front
// and a back surface, diamond-dust scatter inside, and half the light through.
//
// A pose puts the tip at a lateral position (scan units) and a depth (share of the depth axis);
// the shaft leaves the tip towards `yaw_deg` (in the scan plane, from +x towards +y) rising
// towards the viewer at `pitch_deg`. The pose can move: a constant velocity plus a sinusoidal
// tremor, and the forceps' jaws can open and close.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "ioct/hal/raster_scan.hpp"
#include "ioct/recording/recording_format.hpp"

namespace ioct::sim {

enum class InstrumentKind { forceps, needle, scraper };

std::string_view to_string(InstrumentKind kind) noexcept;

struct ToolPose {
  float tip_x = 0.0f;  // scan units
  float tip_y = 0.0f;
  float tip_depth_fraction = 0.3f;  // share of the depth axis (optical path)
  float yaw_deg = 0.0f;
  float pitch_deg = 25.0f;
  float jaw_opening_deg = 0.0f;  // forceps only
  friend bool operator==(const ToolPose&, const ToolPose&) = default;
};

struct ToolMotion {
  float velocity_x = 0.0f;  // scan units per second
  float velocity_y = 0.0f;
  float velocity_depth = 0.0f;  // share of the depth axis per second
  float tremor_x = 0.0f;        // amplitudes of a sinusoidal tremor
  float tremor_y = 0.0f;
  float tremor_depth = 0.0f;
  float tremor_hz = 8.0f;
  float jaw_cycle_deg = 0.0f;  // forceps: the jaws open by this much and close again
  float jaw_cycle_hz = 0.5f;
};

struct InstrumentConfig {
  InstrumentKind kind = InstrumentKind::forceps;
  ToolPose pose;
  ToolMotion motion;

  // Throws ioct::ConfigError ("<prefix>.<key>", e.g. "instruments[0].pose.pitch_deg").
  void validate(std::string_view prefix) const;
};

// Where an instrument is at one moment, for the ground truth.
using ToolState = recording::ToolState;

// What the beam meets first on an instrument.
struct ToolHit {
  bool hit = false;
  float entry_px = 0.0f;
  float exit_px = 0.0f;    // back surface of a translucent part (= entry for metal)
  float amplitude = 0.0f;  // front surface reflection (reflectivity-1 units)
  float back_amplitude = 0.0f;
  float interior_scatter = 0.0f;  // per px, between entry and exit
  float transmission = 0.0f;      // amplitude that goes on below it
};

class InstrumentModel {
 public:
  static constexpr std::size_t kMaxParts = 4;

  // Scan units to mm by field_half_width_mm; depth px to mm of optical path by axial_pixel_um,
  // and to physical mm in the vitreous or aqueous (group index 1.336).
  InstrumentModel(const InstrumentConfig& config, double field_half_width_mm, double axial_pixel_um,
                  std::uint32_t depth_bins);

  const InstrumentConfig& config() const noexcept { return config_; }
  // The pose `seconds` after the start of the acquisition.
  ToolPose pose_at(double seconds) const noexcept;
  ToolState state(const ToolPose& pose) const noexcept;
  // The tool's tip as the instrument detection must find it (its ground truth): the pose's tip
  // point (the centre of a closed tool's rounded end, the middle of the scraper's paddle's
  // leading edge), except for open forceps: the middle of the two jaws' end centres, the metal
  // that meets the tissue first. The closed jaws' point lies in empty space ahead of them, and
  // deeper than either jaw by jaw length x (1 - cos(opening / 2)) x sin(pitch).
  ToolState tip_state(const ToolPose& pose) const noexcept;

  // Builds the instrument's parts for `pose` (no allocation).
  void place(const ToolPose& pose) noexcept;
  // The first part the vertical beam at `beam` meets, in the pose last placed.
  ToolHit hit(hal::BeamPosition beam) const noexcept;

 private:
  struct Vec3 {
    double x, y, z;
  };
  struct Part {
    bool box = false;
    Vec3 a{}, b{};                      // capsule: segment ends; box: centre (a)
    double radius = 0.0;                // capsule
    Vec3 axis_u{}, axis_w{}, axis_n{};  // box axes
    Vec3 half{};                        // box half sizes along u, w, n
    bool metal = true;
  };

  InstrumentConfig config_;
  double field_mm_;
  double px_per_mm_;  // depth px per physical mm in the medium
  double depth_bins_;
  std::array<Part, kMaxParts> parts_{};
  std::size_t part_count_ = 0;
  double min_x_ = 0.0, max_x_ = 0.0, min_y_ = 0.0, max_y_ = 0.0;  // lateral bounds, mm
};

}  // namespace ioct::sim
