// Bad parameters are refused with the key, the value and what would be accepted.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/render/render_config.hpp"

namespace {

using namespace ioct::gpu::render;

void expect_rejected(const std::function<void(RenderConfig&)>& change, const std::string& key) {
  RenderConfig config;
  change(config);
  try {
    config.validate();
    ADD_FAILURE() << "accepted a bad " << key;
  } catch (const ioct::ConfigError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(RenderConfig, DefaultsAreValid) {
  EXPECT_NO_THROW(RenderConfig{}.validate());
  EXPECT_EQ(RenderConfig{}.view.stereo_angle_deg, 9.0);
  EXPECT_GE(RenderConfig{}.view.output_width, 1024u);
  EXPECT_GE(RenderConfig{}.view.output_height, 768u);
  EXPECT_EQ(RenderConfig{}.layer_aware.early_termination, 0.975);
  EXPECT_EQ(RenderConfig{}.layer_aware.shadow_steps, kShadowStepsLimited);
  EXPECT_EQ(kShadowStepsLimited, 20u);
  EXPECT_EQ(kShadowStepsFull, 200u);
}

TEST(RenderConfig, RejectsBadSizesAndViews) {
  expect_rejected([](RenderConfig& c) { c.view.output_width = 0; }, "render.view.output_width");
  expect_rejected([](RenderConfig& c) { c.view.output_height = 100000; },
                  "render.view.output_height");
  expect_rejected([](RenderConfig& c) { c.view.zoom = 0.0; }, "render.view.zoom");
  expect_rejected([](RenderConfig& c) { c.view.elevation_deg = 91.0; },
                  "render.view.elevation_deg");
  expect_rejected([](RenderConfig& c) { c.view.azimuth_deg = kNaN; }, "render.view.azimuth_deg");
  expect_rejected([](RenderConfig& c) { c.view.stereo_angle_deg = -1.0; },
                  "render.view.stereo_angle_deg");
  expect_rejected(
      [](RenderConfig& c) {
        c.view.light_direction = {0.0, 0.0, 0.0};
      },
      "render.view.light_direction");
  expect_rejected([](RenderConfig& c) { c.spacing.depth = -5.0; }, "render.spacing.depth");
  expect_rejected([](RenderConfig& c) { c.step_voxels = 0.0; }, "render.step_voxels");
}

TEST(RenderConfig, RejectsNanAndNegativeCoefficients) {
  expect_rejected([](RenderConfig& c) { c.enhanced.kg1 = kNaN; }, "render.enhanced.kg1");
  expect_rejected([](RenderConfig& c) { c.enhanced.kg2 = 0.0; }, "render.enhanced.kg2");
  expect_rejected([](RenderConfig& c) { c.enhanced.kf1 = -1.0; }, "render.enhanced.kf1");
  expect_rejected([](RenderConfig& c) { c.enhanced.kd1 = 1.5; }, "render.enhanced.kd1");
  expect_rejected([](RenderConfig& c) { c.enhanced.kp4 = INFINITY; }, "render.enhanced.kp4");
  expect_rejected(
      [](RenderConfig& c) {
        c.enhanced.c_b = {0.0, 2.0, 0.0};
      },
      "render.enhanced.c_b[1]");
  expect_rejected([](RenderConfig& c) { c.enhanced.threshold = kNaN; },
                  "render.enhanced.threshold");
}

TEST(RenderConfig, RejectsBadTransferFunctions) {
  expect_rejected([](RenderConfig& c) { c.enhanced.transfer.opacity.clear(); },
                  "render.enhanced.transfer.opacity");
  expect_rejected(
      [](RenderConfig& c) {
        c.enhanced.transfer.opacity = {{0.5, 0.0}, {0.2, 1.0}};
      },
      "render.enhanced.transfer.opacity[1].intensity");
  expect_rejected([](RenderConfig& c) { c.enhanced.transfer.color[0].rgb[2] = kNaN; },
                  "render.enhanced.transfer.color[0].rgb[2]");
}

TEST(RenderConfig, RejectsTooManyAxialShadowSteps) {
  expect_rejected([](RenderConfig& c) { c.axial.shadow_steps = kMaxShadowSteps + 1; },
                  "render.axial.shadow_steps");
}

TEST(RenderConfig, RejectsBadLayerAwareSettings) {
  expect_rejected([](RenderConfig& c) { c.layer_aware.shadow_steps = kMaxShadowSteps + 1; },
                  "render.layer_aware.shadow_steps");
  expect_rejected([](RenderConfig& c) { c.layer_aware.i_max = c.layer_aware.i_min; },
                  "render.layer_aware.i_max");
  expect_rejected([](RenderConfig& c) { c.layer_aware.alpha_max = kNaN; },
                  "render.layer_aware.alpha_max");
  expect_rejected([](RenderConfig& c) { c.layer_aware.colors.d_rpe_px = -3.0; },
                  "render.layer_aware.colors.d_rpe_px");
  expect_rejected([](RenderConfig& c) { c.layer_aware.early_termination = 0.0; },
                  "render.layer_aware.early_termination");
}

TEST(Presets, AnteriorDividesKg1AndKf1ByTen) {
  const EnhancedConfig retina = enhanced_preset(Preset::retina);
  const EnhancedConfig anterior = enhanced_preset(Preset::anterior);
  EXPECT_DOUBLE_EQ(anterior.kg1, retina.kg1 / 10.0);
  EXPECT_DOUBLE_EQ(anterior.kf1, retina.kf1 / 10.0);
  EXPECT_DOUBLE_EQ(anterior.kg2, retina.kg2);
  EXPECT_DOUBLE_EQ(anterior.kp1, retina.kp1);
  EXPECT_EQ(parse_preset("anterior"), Preset::anterior);
  EXPECT_THROW(parse_preset("cornea"), ioct::ConfigError);
}

TEST(Modes, ParseTheirNamesAndRefuseOthers) {
  for (const RenderMode m : {RenderMode::basic, RenderMode::enhanced, RenderMode::layer_aware,
                             RenderMode::axial_colorization, RenderMode::la_mip_composite,
                             RenderMode::bscan_slice, RenderMode::en_face_slice}) {
    EXPECT_EQ(parse_render_mode(to_string(m)), m);
  }
  try {
    parse_render_mode("mip");
    ADD_FAILURE();
  } catch (const ioct::ConfigError& e) {
    EXPECT_EQ(e.key(), "render.mode");
  }
}

}  // namespace
