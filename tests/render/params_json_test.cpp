// The render parameters' JSON (gpu/render/render_params_json): every key is emitted and read back,
// any subset applies, and every bad value, type or key is refused naming its key.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/render/render_params_json.hpp"

namespace ioct::gpu::render {
namespace {

using nlohmann::json;

// Every leaf of a parameters object as a JSON pointer ("/enhanced/kg1").
void leaves(const json& j, const std::string& at, std::set<std::string>& out) {
  if (j.is_object()) {
    for (const auto& [name, value] : j.items()) leaves(value, at + "/" + name, out);
  } else {
    out.insert(at);
  }
}

// A valid value different from the default for every key the parameters have.
const std::map<std::string, json>& other_values() {
  static const std::map<std::string, json> values = {
      {"/mode", "layer-aware"},
      {"/preset", "retina"},  // (the default; anterior is tested on its own)
      {"/view/azimuth_deg", 100.5},
      {"/view/elevation_deg", -10.0},
      {"/view/zoom", 2.5},
      {"/view/pan_x", 0.25},
      {"/view/pan_y", -0.5},
      {"/view/stereo", true},
      {"/view/stereo_angle_deg", 12.0},
      {"/view/auto_rotate", false},
      {"/view/rotation_deg_per_s", -30.0},
      {"/view/light_direction", {0.1, 0.2, 0.9}},
      {"/view/output_width", 640},
      {"/view/output_height", 480},
      {"/enhanced/threshold", 0.5},
      {"/enhanced/kg1", 3.0},
      {"/enhanced/kg2", 2.0},
      {"/enhanced/kf1", 1.0},
      {"/enhanced/kf2", 3.0},
      {"/enhanced/kd1", 0.2},
      {"/enhanced/kd2", 2.5},
      {"/enhanced/kd3", 0.1},
      {"/enhanced/c_b", {0.5, 0.25, 0.75}},
      {"/enhanced/kp1", 0.2},
      {"/enhanced/kp2", 0.5},
      {"/enhanced/kp3", 0.6},
      {"/enhanced/kp4", 32.0},
      {"/enhanced/use_threshold", false},
      {"/enhanced/edge_enhancement", false},
      {"/enhanced/feature_enhancement", false},
      {"/enhanced/depth_cues", false},
      {"/enhanced/phong", false},
      {"/enhanced/transfer/window", {0.1, 0.8}},
      {"/enhanced/transfer/opacity", {{0.0, 0.0}, {0.5, 0.3}, {0.75, 0.4}, {1.0, 0.9}}},
      {"/layer_aware/shadow_steps", 200},
      {"/layer_aware/i_min", 0.2},
      {"/layer_aware/i_max", 0.8},
      {"/layer_aware/alpha_max", 0.7},
      {"/layer_aware/colorize", false},
      {"/axial/phong", true},
      {"/axial/shadow_steps", 20},
      {"/slice/bscan", 7},
  };
  return values;
}

json change_at(const std::string& pointer, const json& value) {
  json changes;
  changes[json::json_pointer(pointer)] = value;
  return changes;
}

TEST(RenderParamsJson, ShowsExactlyTheDocumentedKeys) {
  std::set<std::string> emitted;
  leaves(to_json(RenderConfig{}), "", emitted);
  std::set<std::string> expected;
  for (const auto& [pointer, value] : other_values()) expected.insert(pointer);
  EXPECT_EQ(emitted, expected);
}

TEST(RenderParamsJson, EveryKeyRoundTrips) {
  const RenderConfig base;
  for (const auto& [pointer, value] : other_values()) {
    SCOPED_TRACE(pointer);
    const RenderConfig changed = apply_render_changes(base, change_at(pointer, value));
    const json shown = to_json(changed);
    EXPECT_EQ(shown.at(json::json_pointer(pointer)), value);
    // Nothing else moved.
    json others = shown;
    others[json::json_pointer(pointer)] = to_json(base).at(json::json_pointer(pointer));
    EXPECT_EQ(others, to_json(base));
  }
  // All at once, and the whole object read back equals itself.
  json all;
  for (const auto& [pointer, value] : other_values()) all[json::json_pointer(pointer)] = value;
  const RenderConfig changed = apply_render_changes(base, all);
  EXPECT_EQ(to_json(changed), all);
  EXPECT_EQ(to_json(apply_render_changes(RenderConfig{}, to_json(changed))), all);
}

TEST(RenderParamsJson, EmptyChangesKeepTheConfig) {
  RenderConfig base;
  base.enhanced.kg1 = 5.0;
  EXPECT_EQ(to_json(apply_render_changes(base, json::object())), to_json(base));
}

TEST(RenderParamsJson, PresetIsAppliedBeforeTheOtherKeys) {
  const RenderConfig anterior = apply_render_changes(
      RenderConfig{}, {{"enhanced", {{"threshold", 0.6}}}, {"preset", "anterior"}});
  EXPECT_EQ(anterior.preset, Preset::anterior);
  EXPECT_DOUBLE_EQ(anterior.enhanced.kg1, enhanced_preset(Preset::anterior).kg1);
  EXPECT_DOUBLE_EQ(anterior.enhanced.kf1, enhanced_preset(Preset::anterior).kf1);
  EXPECT_DOUBLE_EQ(anterior.enhanced.threshold, 0.6);  // the explicit key wins over the preset
}

struct BadValue {
  std::string pointer;
  json value;
  std::string key;  // expected ConfigError key
};

TEST(RenderParamsJson, EveryRangeErrorNamesItsKey) {
  const std::vector<BadValue> cases = {
      {"/view/azimuth_deg", 1e6, "render.view.azimuth_deg"},
      {"/view/elevation_deg", 91, "render.view.elevation_deg"},
      {"/view/zoom", 0, "render.view.zoom"},
      {"/view/pan_x", 11, "render.view.pan_x"},
      {"/view/pan_y", -11, "render.view.pan_y"},
      {"/view/stereo_angle_deg", 46, "render.view.stereo_angle_deg"},
      {"/view/rotation_deg_per_s", 4000, "render.view.rotation_deg_per_s"},
      {"/view/light_direction", {0, 0, 0}, "render.view.light_direction"},
      {"/view/output_width", 0, "render.view.output_width"},
      {"/view/output_height", 9000, "render.view.output_height"},
      {"/enhanced/threshold", 1.5, "render.enhanced.threshold"},
      {"/enhanced/kg1", -1, "render.enhanced.kg1"},
      {"/enhanced/kg2", 0, "render.enhanced.kg2"},
      {"/enhanced/kf1", -0.5, "render.enhanced.kf1"},
      {"/enhanced/kf2", -2, "render.enhanced.kf2"},
      {"/enhanced/kd1", 1.1, "render.enhanced.kd1"},
      {"/enhanced/kd2", 0, "render.enhanced.kd2"},
      {"/enhanced/kd3", -0.1, "render.enhanced.kd3"},
      {"/enhanced/c_b", {0.5, 2.0, 0.5}, "render.enhanced.c_b[1]"},
      {"/enhanced/kp1", -1, "render.enhanced.kp1"},
      {"/enhanced/kp2", -1, "render.enhanced.kp2"},
      {"/enhanced/kp3", -1, "render.enhanced.kp3"},
      {"/enhanced/kp4", 0, "render.enhanced.kp4"},
      {"/enhanced/transfer/window", {0.5, 0.5}, "render.enhanced.transfer.window[1]"},
      {"/enhanced/transfer/window", {-0.1, 0.5}, "render.enhanced.transfer.window[0]"},
      {"/enhanced/transfer/opacity",
       {{0.5, 0.1}, {0.2, 0.3}},
       "render.enhanced.transfer.opacity[1].intensity"},
      {"/enhanced/transfer/opacity", {{0.5, 1.5}}, "render.enhanced.transfer.opacity[0].alpha"},
      {"/enhanced/transfer/opacity", json::array(), "render.enhanced.transfer.opacity"},
      {"/layer_aware/shadow_steps", 1001, "render.layer_aware.shadow_steps"},
      {"/layer_aware/i_min", -0.1, "render.layer_aware.i_min"},
      {"/layer_aware/i_max", 0.1, "render.layer_aware.i_max"},  // below i_min
      {"/layer_aware/alpha_max", 2, "render.layer_aware.alpha_max"},
      {"/axial/shadow_steps", 1001, "render.axial.shadow_steps"},
      {"/slice/bscan", -2, "render.slice.bscan"},
      {"/mode", "volume", "render.mode"},
      {"/preset", "cornea", "render.preset"},
  };
  for (const BadValue& c : cases) {
    SCOPED_TRACE(c.pointer + " = " + c.value.dump());
    try {
      (void)apply_render_changes(RenderConfig{}, change_at(c.pointer, c.value));
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), c.key) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.key + " = "), std::string::npos) << e.what();
    }
  }
}

TEST(RenderParamsJson, WrongTypesAndUnknownKeysNameTheKey) {
  const std::vector<BadValue> cases = {
      {"/enhanced/kg1", "8", "render.enhanced.kg1"},
      {"/enhanced/kg1", nullptr, "render.enhanced.kg1"},
      {"/enhanced/phong", 1, "render.enhanced.phong"},
      {"/view/output_width", 512.5, "render.view.output_width"},
      {"/view/output_width", -1, "render.view.output_width"},
      {"/view/light_direction", {1, 2}, "render.view.light_direction"},
      {"/view/light_direction", {1, "up", 2}, "render.view.light_direction[1]"},
      {"/view", 3, "render.view"},
      {"/enhanced/transfer/opacity", {{0.5}}, "render.enhanced.transfer.opacity[0]"},
      {"/enhanced/transfer/opacity", json::array({json::array({0, 0})}).dump(),
       "render.enhanced.transfer.opacity"},
      {"/mode", 2, "render.mode"},
      {"/enhanced/kg9", 1, "render.enhanced.kg9"},
      {"/colour", "red", "render.colour"},
      {"/view/azimuth", 10, "render.view.azimuth"},
      {"/slice/bscan", 1.5, "render.slice.bscan"},
      {"/slice/depth", 3, "render.slice.depth"},
  };
  for (const BadValue& c : cases) {
    SCOPED_TRACE(c.pointer + " = " + c.value.dump());
    try {
      (void)apply_render_changes(RenderConfig{}, change_at(c.pointer, c.value));
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), c.key) << e.what();
    }
  }
  EXPECT_THROW((void)apply_render_changes(RenderConfig{}, json::array()), ConfigError);
}

TEST(RenderParamsJson, TooManyOpacityPointsAreRefusedBeforeCopying) {
  json points = json::array();
  for (std::size_t i = 0; i <= kMaxTransferPoints; ++i) points.push_back({0.0, 0.0});
  try {
    (void)apply_render_changes(RenderConfig{}, change_at("/enhanced/transfer/opacity", points));
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "render.enhanced.transfer.opacity");
  }
}

TEST(RenderParamsJson, CameraChangesTouchOnlyTheView) {
  const RenderConfig moved =
      apply_camera_changes(RenderConfig{}, {{"view", {{"azimuth_deg", 90}, {"zoom", 2}}}});
  EXPECT_DOUBLE_EQ(moved.view.azimuth_deg, 90.0);
  EXPECT_DOUBLE_EQ(moved.view.zoom, 2.0);
  try {
    (void)apply_camera_changes(RenderConfig{}, {{"enhanced", {{"kg1", 1}}}});
    FAIL() << "a viewer changed the shared parameters";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "render.enhanced");
  }
}

TEST(RenderParamsJson, AFailedChangeLeavesTheBaseAlone) {
  RenderConfig base;
  const json before = to_json(base);
  EXPECT_THROW((void)apply_render_changes(
                   base, {{"enhanced", {{"threshold", 0.9}}}, {"view", {{"zoom", -1}}}}),
               ConfigError);
  EXPECT_EQ(to_json(base), before);
}

}  // namespace
}  // namespace ioct::gpu::render
