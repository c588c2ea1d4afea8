// Everything a render needs besides the volume and its surfaces: the view, the voxel spacing, the
// mode and each mode's parameters. The coefficients carry the symbols of the papers they come
// from (Viehland et al. 2016 for the enhanced ray casting, Weiss et al. 2019 for the layer-aware
// modes); the defaults are this project's own (docs/rendering.md). Every struct has validate(),
// which throws ConfigError naming the key ("render.enhanced.kg1 = nan: must be finite ...").
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ioct::gpu::render {

enum class RenderMode : std::uint8_t {
  basic,               // plain front-to-back compositing of the transfer functions (the anchor)
  enhanced,            // Viehland: threshold, edge and feature enhancement, depth cues, Phong
  layer_aware,         // Weiss: L*a*b* map relative to the RPE, linear opacity, shadow rays
  axial_colorization,  // baseline: enhanced ray casting coloured by depth below a fixed plane
  la_mip_composite,    // en face MIP beside two Layer-Adjusted MIPs
  bscan_slice,         // one B-scan, grey
  en_face_slice,       // one depth (or one depth relative to the RPE), grey
};

std::string_view to_string(RenderMode mode) noexcept;
// Throws ConfigError naming `key` for an unknown name.
RenderMode parse_render_mode(std::string_view name, std::string_view key = "render.mode");
// The 3D modes are rendered from the orbit view (and as stereo pairs).
bool is_volume_mode(RenderMode mode) noexcept;

// Orbit camera around the volume's centre, orthographic. World axes: x along the A-scans of a
// B-scan, y across B-scans, z up (against the depth axis). Azimuth turns about z; azimuth 0 and
// elevation 0 look along +y at the first B-scan's face, elevation 90 looks down the A-scans.
struct ViewConfig {
  double azimuth_deg = 30.0;
  double elevation_deg = 25.0;  // inclination against the tissue plane (the surgeons' 25 deg)
  double zoom = 1.0;            // 1: the volume's bounding sphere fits the image height
  double pan_x = 0.0;           // image-plane shift, in units of the volume's largest extent
  double pan_y = 0.0;
  bool stereo = false;            // side by side: left eye | right eye, each output_width wide
  double stereo_angle_deg = 9.0;  // the eyes sit at azimuth -/+ half of this
  std::uint32_t output_width = 1024;
  std::uint32_t output_height = 768;
  // Light direction in camera space (x right, y up, z towards the viewer), normalised on use.
  std::array<double, 3> light_direction{-0.4, 0.6, 0.7};
  // Automatic rotation for live display and turntables (deg/s), as the surgeons suggested.
  bool auto_rotate = true;
  double rotation_deg_per_s = 45.0;

  void validate() const;  // "render.view.<key>"
};

// Physical size of a voxel in micrometres: gives the rendered aspect (and d_rpe's fallback).
struct VoxelSpacing {
  double ascan = 11.74;  // between neighbouring A-scans of a B-scan
  double bscan = 47.24;  // between neighbouring B-scans
  double depth = 5.605;  // along the A-scan

  void validate() const;  // "render.spacing.<key>"
};

// A piecewise-linear function of the intensity I in [0, 1], given at increasing I.
struct ColorPoint {
  double intensity = 0.0;
  std::array<double, 3> rgb{0.0, 0.0, 0.0};
  bool operator==(const ColorPoint&) const = default;
};
struct OpacityPoint {
  double intensity = 0.0;
  double alpha = 0.0;
  bool operator==(const OpacityPoint&) const = default;
};

// At most this many points per function (the functions come from viewers too).
inline constexpr std::size_t kMaxTransferPoints = 64;

struct TransferFunctions {
  // Intensity window [lo, hi]: the functions are read at (I - lo) / (hi - lo), clamped to [0, 1],
  // so the assistant can stretch the tissue's range over the whole ramp.
  std::array<double, 2> window{0.0, 1.0};
  std::vector<ColorPoint> color{
      {0.0, {0.55, 0.45, 0.40}}, {0.6, {0.95, 0.85, 0.75}}, {1.0, {1.0, 1.0, 1.0}}};
  std::vector<OpacityPoint> opacity{{0.0, 0.0}, {0.35, 0.05}, {1.0, 0.6}};

  void validate(std::string_view key) const;
  bool operator==(const TransferFunctions&) const = default;  // (the CUDA renderer's table cache)
};

// Viehland et al. 2016, Eqs. (1)-(5); each step can be switched off (their Fig. 4 progression).
struct EnhancedConfig {
  bool use_threshold = true;
  double threshold = 0.35;  // intensity below which a sample is empty

  bool edge_enhancement = true;  // Eq. (2): alpha * (1 + kg1 |grad|^kg2)
  double kg1 = 8.0;
  double kg2 = 1.0;
  bool feature_enhancement = true;  // Eq. (3): * (1 + kf1 (1 - |N.V|)^kf2)
  double kf1 = 2.0;
  double kf2 = 2.0;
  bool depth_cues = true;  // Eq. (4): c (1 - kd1 dv^kd2) + kd3 dv^kd2 c_b
  double kd1 = 0.6;
  double kd2 = 1.5;
  double kd3 = 0.35;
  std::array<double, 3> c_b{0.15, 0.3, 1.0};
  bool phong = true;  // Eq. (5): c (kp1 + kp2 N.L + kp3 (N.H)^kp4)
  double kp1 = 0.35;
  double kp2 = 0.75;
  double kp3 = 0.35;
  double kp4 = 16.0;

  TransferFunctions transfer;

  void validate() const;  // "render.enhanced.<key>"
};

enum class Preset : std::uint8_t { retina, anterior };
std::string_view to_string(Preset preset) noexcept;
Preset parse_preset(std::string_view name);  // ConfigError "render.preset"
// The retina preset is EnhancedConfig{}; the anterior one divides kg1 and kf1 by 10 (the
// cornea and lens are large smooth surfaces where edge boosting only adds haze).
EnhancedConfig enhanced_preset(Preset preset);

// The chroma scaling of Weiss et al. Eq. (1). The paper prints 1 - (I - 0.5)^2 but states that
// gamma(0) = gamma(1) = 0; stated_properties uses 1 - 4 (I - 0.5)^2, which has them.
enum class ChromaCurve : std::uint8_t { stated_properties, as_printed };

// Weiss et al. 2019, Sec. 3.1: L* = 100 I, (a*, b*) = ab_scale gamma(I) ((1-d) C0 + d C1) with
// d = delta* = clamp((delta + 1) / 3), delta = (depth - rpe) / d_rpe.
struct LabColorMap {
  std::array<double, 2> c0{-0.5, -0.5};  // (a*, b*) at delta* = 0: blue
  std::array<double, 2> c1{0.75, 0.75};  // (a*, b*) at delta* = 1: red
  double ab_scale = 100.0;               // the paper's a*b* units to CIE a*b*
  ChromaCurve chroma_curve = ChromaCurve::stated_properties;
  // d_rpe, the average retinal thickness in depth px; 0: measured from the surfaces (mean of
  // rpe - ilm), or kDefaultRetinaThicknessUm of depth where the surfaces do not give it.
  double d_rpe_px = 0.0;

  void validate(std::string_view key) const;
  bool operator==(const LabColorMap&) const = default;  // (the CUDA renderer's table cache)
};

inline constexpr double kDefaultRetinaThicknessUm = 250.0;

// Named shadow settings of Weiss et al. (N_s = 20 limited, 200 full).
inline constexpr std::uint32_t kShadowStepsLimited = 20;
inline constexpr std::uint32_t kShadowStepsFull = 200;
inline constexpr std::uint32_t kMaxShadowSteps = 1000;

// Weiss et al. 2019, Sec. 3.2, Eqs. (2)-(3).
struct LayerAwareConfig {
  double i_min = 0.3;  // linear opacity transfer function: 0 at i_min ...
  double i_max = 0.9;  // ... alpha_max at i_max and above
  double alpha_max = 0.5;
  bool colorize = true;                              // false: L* only (their Fig. 4 A1)
  std::uint32_t shadow_steps = kShadowStepsLimited;  // N_s; 0: no shadows
  double early_termination = 0.975;                  // stop a ray once its opacity exceeds this
  LabColorMap colors;

  void validate() const;  // "render.layer_aware.<key>"
};

// Axial colorization baseline: enhanced ray casting whose colour is the L*a*b* map of the depth
// below a plane at the volume's intensity centre of mass (one plane for the whole volume).
struct AxialColorizationConfig {
  bool phong = false;  // their Fig. 4 B2 (no Phong) and B3 (with)
  // N_s of shadow rays instead of Phong (their Fig. 4 B4), through the enhanced transfer
  // function's opacity (threshold included); 0: none. Above 0 they replace Phong, whatever
  // `phong` says.
  std::uint32_t shadow_steps = 0;

  void validate() const;  // "render.axial.<key>"
};

struct SliceConfig {
  std::int64_t bscan = -1;               // B-scan shown; -1: the centre one
  double en_face_depth_px = -1;          // en face slice depth; -1: the centre depth
  bool en_face_relative_to_rpe = false;  // then en_face_depth_px is the offset below the RPE

  void validate() const;  // "render.slice.<key>"
};

struct RenderConfig {
  RenderMode mode = RenderMode::enhanced;
  Preset preset = Preset::retina;  // the preset `enhanced` was last set from
  ViewConfig view;
  VoxelSpacing spacing;
  double step_voxels = 1.0;          // ray step: at most this many voxels along any axis per sample
  double early_termination = 0.975;  // basic and enhanced: stop once opacity exceeds this
  EnhancedConfig enhanced;
  LayerAwareConfig layer_aware;
  AxialColorizationConfig axial;
  SliceConfig slice;
  std::array<double, 3> background{0.0, 0.0, 0.0};
  std::uint32_t cpu_threads = 0;  // CPU renderer; 0: the hardware's

  void validate() const;  // "render.<key>"
};

}  // namespace ioct::gpu::render
