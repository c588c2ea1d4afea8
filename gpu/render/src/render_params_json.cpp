#include "ioct/gpu/render/render_params_json.hpp"

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "ioct/common/config_error.hpp"
#include "ioct/common/strict_json.hpp"

namespace ioct::gpu::render {
namespace {

using nlohmann::json;

// A value as an error message shows it: escaped and short, since it may come from anyone.
std::string shown(const json& value) {
  return shown_json(value);
}

[[noreturn]] void wrong_type(const std::string& key, const json& value, std::string_view what) {
  throw ConfigError(key, shown(value), "must be " + std::string(what));
}

double real(const std::string& key, const json& value) {
  if (!value.is_number()) wrong_type(key, value, "a number");
  return value.get<double>();
}

bool boolean(const std::string& key, const json& value) {
  if (!value.is_boolean()) wrong_type(key, value, "true or false");
  return value.get<bool>();
}

std::int64_t integer(const std::string& key, const json& value) {
  if (value.is_number_unsigned()) {
    if (value.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)) {
      wrong_type(key, value, "a whole number below 2^63");
    }
    return static_cast<std::int64_t>(value.get<std::uint64_t>());
  }
  if (!value.is_number_integer()) wrong_type(key, value, "a whole number");
  return value.get<std::int64_t>();
}

// An unsigned 32-bit field: the type's bounds here, the field's range in validate().
std::uint32_t count(const std::string& key, const json& value) {
  const std::int64_t n = integer(key, value);
  if (n < 0 || n > std::int64_t{std::numeric_limits<std::uint32_t>::max()}) {
    wrong_type(key, value, "a whole number from 0 to 4294967295");
  }
  return static_cast<std::uint32_t>(n);
}

std::string text(const std::string& key, const json& value) {
  if (!value.is_string()) wrong_type(key, value, "a string");
  return value.get<std::string>();
}

const json& object(const std::string& key, const json& value) {
  if (!value.is_object()) wrong_type(key, value, "an object");
  return value;
}

template <std::size_t N>
std::array<double, N> reals(const std::string& key, const json& value) {
  if (!value.is_array() || value.size() != N) {
    wrong_type(key, value, "an array of " + std::to_string(N) + " numbers");
  }
  std::array<double, N> out{};
  for (std::size_t i = 0; i < N; ++i) out[i] = real(key + "[" + std::to_string(i) + "]", value[i]);
  return out;
}

[[noreturn]] void unknown(const std::string& key, const json& value) {
  throw ConfigError(key, shown(value), "is not a render parameter");
}

void apply_view(const std::string& p, const json& changes, ViewConfig& v) {
  for (const auto& [name, value] : object(p, changes).items()) {
    const std::string key = p + "." + name;
    if (name == "azimuth_deg") {
      v.azimuth_deg = real(key, value);
    } else if (name == "elevation_deg") {
      v.elevation_deg = real(key, value);
    } else if (name == "zoom") {
      v.zoom = real(key, value);
    } else if (name == "pan_x") {
      v.pan_x = real(key, value);
    } else if (name == "pan_y") {
      v.pan_y = real(key, value);
    } else if (name == "stereo") {
      v.stereo = boolean(key, value);
    } else if (name == "stereo_angle_deg") {
      v.stereo_angle_deg = real(key, value);
    } else if (name == "auto_rotate") {
      v.auto_rotate = boolean(key, value);
    } else if (name == "rotation_deg_per_s") {
      v.rotation_deg_per_s = real(key, value);
    } else if (name == "light_direction") {
      v.light_direction = reals<3>(key, value);
    } else if (name == "output_width") {
      v.output_width = count(key, value);
    } else if (name == "output_height") {
      v.output_height = count(key, value);
    } else {
      unknown(key, value);
    }
  }
}

void apply_transfer(const std::string& p, const json& changes, TransferFunctions& t) {
  for (const auto& [name, value] : object(p, changes).items()) {
    const std::string key = p + "." + name;
    if (name == "window") {
      t.window = reals<2>(key, value);
    } else if (name == "opacity") {
      // Checked before it is copied: the list comes from outside.
      if (!value.is_array() || value.size() > kMaxTransferPoints) {
        wrong_type(key, value,
                   "an array of at most " + std::to_string(kMaxTransferPoints) +
                       " [intensity, alpha] pairs");
      }
      t.opacity.clear();
      for (std::size_t i = 0; i < value.size(); ++i) {
        const auto point = reals<2>(key + "[" + std::to_string(i) + "]", value[i]);
        t.opacity.push_back({point[0], point[1]});
      }
    } else {
      unknown(key, value);
    }
  }
}

void apply_enhanced(const std::string& p, const json& changes, EnhancedConfig& e) {
  struct Coefficient {
    std::string_view name;
    double EnhancedConfig::*field;
  };
  static constexpr Coefficient kCoefficients[] = {{"threshold", &EnhancedConfig::threshold},
                                                  {"kg1", &EnhancedConfig::kg1},
                                                  {"kg2", &EnhancedConfig::kg2},
                                                  {"kf1", &EnhancedConfig::kf1},
                                                  {"kf2", &EnhancedConfig::kf2},
                                                  {"kd1", &EnhancedConfig::kd1},
                                                  {"kd2", &EnhancedConfig::kd2},
                                                  {"kd3", &EnhancedConfig::kd3},
                                                  {"kp1", &EnhancedConfig::kp1},
                                                  {"kp2", &EnhancedConfig::kp2},
                                                  {"kp3", &EnhancedConfig::kp3},
                                                  {"kp4", &EnhancedConfig::kp4}};
  struct Switch {
    std::string_view name;
    bool EnhancedConfig::*field;
  };
  static constexpr Switch kSwitches[] = {
      {"use_threshold", &EnhancedConfig::use_threshold},
      {"edge_enhancement", &EnhancedConfig::edge_enhancement},
      {"feature_enhancement", &EnhancedConfig::feature_enhancement},
      {"depth_cues", &EnhancedConfig::depth_cues},
      {"phong", &EnhancedConfig::phong}};
  for (const auto& [name, value] : object(p, changes).items()) {
    const std::string key = p + "." + name;
    bool known = false;
    for (const Coefficient& c : kCoefficients) {
      if (name == c.name) {
        e.*c.field = real(key, value);
        known = true;
      }
    }
    for (const Switch& s : kSwitches) {
      if (name == s.name) {
        e.*s.field = boolean(key, value);
        known = true;
      }
    }
    if (known) continue;
    if (name == "c_b") {
      e.c_b = reals<3>(key, value);
    } else if (name == "transfer") {
      apply_transfer(key, value, e.transfer);
    } else {
      unknown(key, value);
    }
  }
}

void apply_layer_aware(const std::string& p, const json& changes, LayerAwareConfig& l) {
  for (const auto& [name, value] : object(p, changes).items()) {
    const std::string key = p + "." + name;
    if (name == "shadow_steps") {
      l.shadow_steps = count(key, value);
    } else if (name == "i_min") {
      l.i_min = real(key, value);
    } else if (name == "i_max") {
      l.i_max = real(key, value);
    } else if (name == "alpha_max") {
      l.alpha_max = real(key, value);
    } else if (name == "colorize") {
      l.colorize = boolean(key, value);
    } else {
      unknown(key, value);
    }
  }
}

void apply_axial(const std::string& p, const json& changes, AxialColorizationConfig& a) {
  for (const auto& [name, value] : object(p, changes).items()) {
    const std::string key = p + "." + name;
    if (name == "phong") {
      a.phong = boolean(key, value);
    } else if (name == "shadow_steps") {
      a.shadow_steps = count(key, value);
    } else {
      unknown(key, value);
    }
  }
}

void apply_slice(const std::string& p, const json& changes, SliceConfig& s) {
  for (const auto& [name, value] : object(p, changes).items()) {
    const std::string key = p + "." + name;
    if (name == "bscan") {
      s.bscan = integer(key, value);
    } else {
      unknown(key, value);
    }
  }
}

}  // namespace

nlohmann::json to_json(const RenderConfig& c) {
  const ViewConfig& v = c.view;
  const EnhancedConfig& e = c.enhanced;
  const LayerAwareConfig& l = c.layer_aware;
  json opacity = json::array();
  for (const OpacityPoint& point : e.transfer.opacity) {
    opacity.push_back({point.intensity, point.alpha});
  }
  return {
      {"mode", std::string(to_string(c.mode))},
      {"preset", std::string(to_string(c.preset))},
      {"view",
       {{"azimuth_deg", v.azimuth_deg},
        {"elevation_deg", v.elevation_deg},
        {"zoom", v.zoom},
        {"pan_x", v.pan_x},
        {"pan_y", v.pan_y},
        {"stereo", v.stereo},
        {"stereo_angle_deg", v.stereo_angle_deg},
        {"auto_rotate", v.auto_rotate},
        {"rotation_deg_per_s", v.rotation_deg_per_s},
        {"light_direction", v.light_direction},
        {"output_width", v.output_width},
        {"output_height", v.output_height}}},
      {"enhanced",
       {{"threshold", e.threshold},
        {"kg1", e.kg1},
        {"kg2", e.kg2},
        {"kf1", e.kf1},
        {"kf2", e.kf2},
        {"kd1", e.kd1},
        {"kd2", e.kd2},
        {"kd3", e.kd3},
        {"c_b", e.c_b},
        {"kp1", e.kp1},
        {"kp2", e.kp2},
        {"kp3", e.kp3},
        {"kp4", e.kp4},
        {"use_threshold", e.use_threshold},
        {"edge_enhancement", e.edge_enhancement},
        {"feature_enhancement", e.feature_enhancement},
        {"depth_cues", e.depth_cues},
        {"phong", e.phong},
        {"transfer", {{"window", e.transfer.window}, {"opacity", opacity}}}}},
      {"layer_aware",
       {{"shadow_steps", l.shadow_steps},
        {"i_min", l.i_min},
        {"i_max", l.i_max},
        {"alpha_max", l.alpha_max},
        {"colorize", l.colorize}}},
      {"axial", {{"phong", c.axial.phong}, {"shadow_steps", c.axial.shadow_steps}}},
      {"slice", {{"bscan", c.slice.bscan}}},
  };
}

RenderConfig apply_render_changes(const RenderConfig& base, const nlohmann::json& changes) {
  const std::string p = "render";
  RenderConfig c = base;
  object(p, changes);
  if (const auto preset = changes.find("preset"); preset != changes.end()) {
    c.preset = parse_preset(text(p + ".preset", *preset));
    c.enhanced = enhanced_preset(c.preset);
  }
  for (const auto& [name, value] : changes.items()) {
    const std::string key = p + "." + name;
    if (name == "preset") {
      continue;
    } else if (name == "mode") {
      c.mode = parse_render_mode(text(key, value));
    } else if (name == "view") {
      apply_view(key, value, c.view);
    } else if (name == "enhanced") {
      apply_enhanced(key, value, c.enhanced);
    } else if (name == "layer_aware") {
      apply_layer_aware(key, value, c.layer_aware);
    } else if (name == "axial") {
      apply_axial(key, value, c.axial);
    } else if (name == "slice") {
      apply_slice(key, value, c.slice);
    } else {
      unknown(key, value);
    }
  }
  c.validate();
  return c;
}

RenderConfig apply_camera_changes(const RenderConfig& base, const nlohmann::json& changes) {
  for (const auto& [name, value] : object("render", changes).items()) {
    if (name != "view") {
      throw ConfigError("render." + name, shown(value),
                        "cannot be changed for one viewer (only render.view)");
    }
  }
  return apply_render_changes(base, changes);
}

}  // namespace ioct::gpu::render
