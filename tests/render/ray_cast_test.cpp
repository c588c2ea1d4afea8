// The CPU reference's ray casting against what can be worked out by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "analytic_volumes.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/gpu/render/cpu_renderer.hpp"
#include "ioct/gpu/render/frame_setup.hpp"

namespace {

using namespace ioct::gpu;
using namespace ioct::gpu::render;
using ioct::render_test::make_slabs;
using ioct::render_test::make_sphere;
using ioct::render_test::Slab;

RenderConfig isotropic(std::uint32_t w, std::uint32_t h) {
  RenderConfig c;
  c.spacing = {1.0, 1.0, 1.0};
  c.view.output_width = w;
  c.view.output_height = h;
  c.cpu_threads = 2;
  return c;
}

// Grey ramps: colour = intensity, opacity = intensity (or a constant opacity).
TransferFunctions grey_ramp() {
  TransferFunctions t;
  t.color = {{0.0, {0.0, 0.0, 0.0}}, {1.0, {1.0, 1.0, 1.0}}};
  t.opacity = {{0.0, 0.0}, {1.0, 1.0}};
  return t;
}

double channel(const RgbaImage& image, std::uint32_t x, std::uint32_t y, int c) {
  return image.pixel(x, y)[c] / 255.0;
}

TEST(SphereSilhouette, CoversTheProjectedDiskFromEveryView) {
  const std::uint32_t n = 48;
  const double radius = 14.0;
  const Volume sphere = make_sphere(n, radius, 2.0);
  RenderConfig config = isotropic(96, 96);
  config.mode = RenderMode::basic;
  config.enhanced.use_threshold = true;
  config.enhanced.threshold = 0.5;
  config.enhanced.transfer.opacity = {{0.0, 1.0}, {1.0, 1.0}};
  CpuRenderer renderer(2);
  renderer.set_volume(sphere, nullptr);
  // Image-plane scale: the half height is the box's bounding radius (zoom 1); the largest
  // extent (n voxels) is one world unit.
  const double half_height = std::sqrt(3.0) * 0.5;
  const double px_per_world = 96 / (2.0 * half_height);
  const double radius_px = radius / n * px_per_world;
  for (const auto& [azimuth, elevation] :
       std::vector<std::pair<double, double>>{{0, 0}, {30, 25}, {-70, 60}, {200, -40}, {10, 90}}) {
    config.view.azimuth_deg = azimuth;
    config.view.elevation_deg = elevation;
    RgbaImage image;
    renderer.render(config, image);
    int covered = 0;
    int wrong = 0;
    for (std::uint32_t y = 0; y < 96; ++y) {
      for (std::uint32_t x = 0; x < 96; ++x) {
        const bool hit = image.pixel(x, y)[3] > 127;
        covered += hit;
        const double r = std::hypot(x + 0.5 - 48.0, y + 0.5 - 48.0);
        if ((r < radius_px - 1.0 && !hit) || (r > radius_px + 1.0 && hit)) ++wrong;
      }
    }
    const double disk = std::numbers::pi * radius_px * radius_px;
    EXPECT_NEAR(covered, disk, 0.04 * disk) << "azimuth " << azimuth << " elevation " << elevation;
    EXPECT_EQ(wrong, 0) << "azimuth " << azimuth << " elevation " << elevation;
  }
}

TEST(SphereShading, FollowsLambertWithTheRadialNormal) {
  const std::uint32_t n = 64;
  const double radius = 20.0;
  const Volume sphere = make_sphere(n, radius, 6.0);
  RenderConfig config = isotropic(128, 128);
  config.mode = RenderMode::enhanced;
  config.view.azimuth_deg = 35.0;
  config.view.elevation_deg = 20.0;
  config.view.light_direction = {-0.5, 0.5, 0.7};
  EnhancedConfig& e = config.enhanced;
  e.use_threshold = true;
  e.threshold = 0.5;
  e.edge_enhancement = e.feature_enhancement = e.depth_cues = false;
  e.phong = true;
  e.kp1 = 0.2;
  e.kp2 = 0.8;
  e.kp3 = 0.0;
  e.transfer.color = {{0.0, {1.0, 1.0, 1.0}}, {1.0, {1.0, 1.0, 1.0}}};
  e.transfer.opacity = {{0.0, 1.0}, {1.0, 1.0}};
  config.step_voxels = 0.25;
  CpuRenderer renderer(2);
  renderer.set_volume(sphere, nullptr);
  RgbaImage image;
  renderer.render(config, image);

  const double l_norm = std::sqrt(0.25 + 0.25 + 0.49);
  const double lx = -0.5 / l_norm, ly = 0.5 / l_norm, lz = 0.7 / l_norm;
  const double half_height = std::sqrt(3.0) * 0.5;
  const double radius_px = radius / n * 128 / (2.0 * half_height);
  int checked = 0;
  double worst = 0.0;
  double brightest = 0.0, darkest = 1.0;
  for (std::uint32_t y = 0; y < 128; ++y) {
    for (std::uint32_t x = 0; x < 128; ++x) {
      // Camera-space normal of the sphere where this pixel's ray meets it.
      const double sx = (x + 0.5 - 64.0) / radius_px;
      const double sy = (64.0 - y - 0.5) / radius_px;
      const double s2 = sx * sx + sy * sy;
      if (s2 > 0.8 * 0.8) continue;
      const double nz = std::sqrt(1.0 - s2);
      const double expected = 0.2 + 0.8 * std::max(0.0, sx * lx + sy * ly + nz * lz);
      const double got = channel(image, x, y, 0);
      worst = std::max(worst, std::fabs(got - expected));
      brightest = std::max(brightest, got);
      darkest = std::min(darkest, got);
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_LT(worst, 0.05);
  EXPECT_GT(brightest - darkest, 0.4);  // the test would not notice a flat disk otherwise
}

// Looking straight down the A-scans, samples fall on the depth px (step 1 voxel), so the
// compositing of uniform slabs can be summed by hand.
double composite_by_hand(const std::vector<double>& alphas, const std::vector<double>& colors,
                         double termination, double* alpha_out) {
  double c = 0.0, a = 0.0;
  for (std::size_t i = 0; i < alphas.size(); ++i) {
    c += (1.0 - a) * alphas[i] * colors[i];
    a += (1.0 - a) * alphas[i];
    if (a > termination) break;
  }
  if (alpha_out != nullptr) *alpha_out = a;
  return c;
}

RenderConfig top_view_config() {
  RenderConfig config;
  config.spacing = {16.0, 16.0, 1.0};  // 8 x 8 A-scans of 128 px: a cube
  config.view.output_width = 16;
  config.view.output_height = 16;
  config.view.elevation_deg = 90.0;
  config.view.azimuth_deg = 0.0;
  config.mode = RenderMode::basic;
  config.enhanced.use_threshold = false;
  config.enhanced.transfer = grey_ramp();
  config.cpu_threads = 1;
  return config;
}

TEST(SlabCompositing, MatchesTheFrontToBackSum) {
  const Slab slabs[] = {{20, 30, 64}, {50, 70, 153}, {90, 100, 230}};
  const Volume volume = make_slabs(8, 128, slabs, 3);
  RenderConfig config = top_view_config();
  config.early_termination = 1.0;  // never
  const RgbaImage image = render_volume(volume, nullptr, config);
  std::vector<double> alphas, colors;
  for (std::uint32_t d = 0; d < 128; ++d) {
    const double v = volume.at(4, 4, d) / 255.0;
    alphas.push_back(v);
    colors.push_back(v);
  }
  double alpha = 0.0;
  const double expected = composite_by_hand(alphas, colors, 2.0, &alpha);
  EXPECT_NEAR(channel(image, 8, 8, 0), expected, 1.0 / 255.0);
  EXPECT_NEAR(channel(image, 8, 8, 3), alpha, 1.0 / 255.0);
  // Front to back: the first slab hides the later ones in proportion to its opacity.
  const Slab reversed[] = {{20, 30, 230}, {50, 70, 153}, {90, 100, 64}};
  const RgbaImage other = render_volume(make_slabs(8, 128, reversed, 3), nullptr, config);
  std::vector<double> a2, c2;
  for (std::uint32_t d = 0; d < 128; ++d) {
    double v = 0.0;
    for (const Slab& s : reversed) v = d >= s.begin && d < s.end ? s.value / 255.0 : v;
    a2.push_back(v);
    c2.push_back(v);
  }
  EXPECT_NEAR(channel(other, 8, 8, 0), composite_by_hand(a2, c2, 2.0, nullptr), 1.0 / 255.0);
  EXPECT_GT(std::fabs(channel(other, 8, 8, 0) - channel(image, 8, 8, 0)), 0.05);
}

TEST(EarlyTermination, StopsOnceTheOpacityExceedsTheLimit) {
  // A dark slab of opacity 0.31 per sample, then a bright opaque one: without termination some
  // of the bright slab shows through; with termination at 0.9 the ray stops inside the dark slab
  // (after 7 of its 10 samples).
  const Slab slabs[] = {{10, 20, 80}, {40, 60, 255}};
  const Volume volume = make_slabs(8, 128, slabs, 2);
  RenderConfig config = top_view_config();
  config.enhanced.transfer.color = {
      {0.0, {0.0, 0.0, 0.0}}, {0.6, {0.0, 0.0, 0.0}}, {1.0, {1.0, 1.0, 1.0}}};
  config.enhanced.transfer.opacity = {{0.0, 0.0}, {1.0, 1.0}};
  const double a_dark = 80.0 / 255.0;

  config.early_termination = 0.9;
  const RgbaImage stopped = render_volume(volume, nullptr, config);
  double a = 0.0;
  int samples = 0;
  while (a <= 0.9) {
    a += (1.0 - a) * a_dark;
    ++samples;
  }
  EXPECT_LT(samples, 10);  // it stops inside the dark slab
  EXPECT_NEAR(channel(stopped, 8, 8, 3), a, 1.0 / 255.0);
  EXPECT_EQ(stopped.pixel(8, 8)[0], 0);

  config.early_termination = 1.0;
  const RgbaImage full = render_volume(volume, nullptr, config);
  const double behind = std::pow(1.0 - a_dark, 10.0);  // transmittance of the whole dark slab
  EXPECT_NEAR(channel(full, 8, 8, 0), behind, 1.5 / 255.0);
  EXPECT_GT(full.pixel(8, 8)[0], 0);
}

TEST(EnhancedSteps, AllSwitchedOffIsTheBasicRayCaster) {
  const Volume sphere = make_sphere(32, 10.0, 4.0);
  RenderConfig config = isotropic(48, 40);
  config.enhanced.edge_enhancement = config.enhanced.feature_enhancement = false;
  config.enhanced.depth_cues = config.enhanced.phong = false;
  config.mode = RenderMode::enhanced;
  const RgbaImage enhanced = render_volume(sphere, nullptr, config);
  config.mode = RenderMode::basic;
  const RgbaImage basic = render_volume(sphere, nullptr, config);
  EXPECT_EQ(enhanced.rgba, basic.rgba);
}

TEST(EnhancedSteps, EachStepChangesTheImage) {
  const Volume sphere = make_sphere(32, 10.0, 6.0);
  RenderConfig config = isotropic(48, 40);
  config.mode = RenderMode::enhanced;
  EnhancedConfig& e = config.enhanced;
  e.transfer.opacity = {{0.0, 0.0}, {1.0, 0.2}};
  e.edge_enhancement = e.feature_enhancement = e.depth_cues = e.phong = false;
  RgbaImage previous = render_volume(sphere, nullptr, config);
  for (bool EnhancedConfig::*step :
       {&EnhancedConfig::edge_enhancement, &EnhancedConfig::feature_enhancement,
        &EnhancedConfig::depth_cues, &EnhancedConfig::phong}) {
    e.*step = true;
    const RgbaImage next = render_volume(sphere, nullptr, config);
    EXPECT_NE(next.rgba, previous.rgba);
    previous = next;
  }
}

// Weiss Fig. 4 B4: shadow rays only darken the axial colorization's samples (their opacity is
// unchanged), so no pixel of B4 is brighter than B2's (no Phong, no shadows) and the image as a
// whole is darker; with N_s = 0 it is B2.
TEST(AxialShadowRays, DarkenTheAxialColorizationAndNothingElse) {
  const auto retina = ioct::render_test::make_synthetic_retina(24, 96, 128);
  CpuRenderer renderer(2);
  renderer.set_volume(retina.volume, &retina.surfaces);
  RenderConfig config = isotropic(160, 120);
  config.mode = RenderMode::axial_colorization;
  config.view.elevation_deg = 25.0;
  config.view.azimuth_deg = 30.0;
  RgbaImage b2, b4, none;
  renderer.render(config, b2);
  config.axial.shadow_steps = kShadowStepsFull;
  renderer.render(config, b4);
  config.axial.phong = true;  // replaced by the shadow rays
  RgbaImage b4_phong_asked;
  renderer.render(config, b4_phong_asked);
  EXPECT_EQ(b4_phong_asked.rgba, b4.rgba);
  config.axial.phong = false;
  config.axial.shadow_steps = 0;
  renderer.render(config, none);
  EXPECT_EQ(none.rgba, b2.rgba);
  double sum_b2 = 0.0, sum_b4 = 0.0;
  for (std::size_t i = 0; i < b2.rgba.size(); ++i) {
    if (i % 4 == 3) {
      ASSERT_EQ(b4.rgba[i], b2.rgba[i]) << "opacity of pixel " << i / 4;
      continue;
    }
    ASSERT_LE(b4.rgba[i], b2.rgba[i]) << "pixel " << i / 4 << " channel " << i % 4;
    sum_b2 += b2.rgba[i];
    sum_b4 += b4.rgba[i];
  }
  ASSERT_GT(sum_b2, 0.0);
  EXPECT_LT(sum_b4, 0.95 * sum_b2) << "the shadow rays darken the image by less than 5 %";
}

TEST(DepthCues, DimAndTintTheFarSide) {
  // Two equal slabs seen from above: the deeper one is dimmer and bluer.
  const Slab slabs[] = {{10, 12, 255}};
  const Slab deep[] = {{110, 112, 255}};
  RenderConfig config = top_view_config();
  config.mode = RenderMode::enhanced;
  config.enhanced.edge_enhancement = config.enhanced.feature_enhancement = false;
  config.enhanced.phong = false;
  config.enhanced.depth_cues = true;
  config.enhanced.transfer.color = {{0.0, {1.0, 1.0, 1.0}}, {1.0, {1.0, 1.0, 1.0}}};
  config.enhanced.transfer.opacity = {{0.0, 1.0}, {1.0, 1.0}};
  config.enhanced.use_threshold = true;
  config.enhanced.threshold = 0.5;
  const RgbaImage near = render_volume(make_slabs(8, 128, slabs, 1), nullptr, config);
  const RgbaImage far = render_volume(make_slabs(8, 128, deep, 1), nullptr, config);
  EXPECT_LT(far.pixel(8, 8)[0], near.pixel(8, 8)[0]);
  const double far_blue_share = far.pixel(8, 8)[2] / (far.pixel(8, 8)[0] + 1.0);
  const double near_blue_share = near.pixel(8, 8)[2] / (near.pixel(8, 8)[0] + 1.0);
  EXPECT_GT(far_blue_share, near_blue_share);
}

TEST(Stereo, IsTwoViewsTheStereoAngleApartSideBySide) {
  const Volume sphere = make_sphere(24, 8.0, 4.0);
  RenderConfig config = isotropic(32, 24);
  config.view.azimuth_deg = 20.0;
  config.view.stereo = true;
  config.view.stereo_angle_deg = 9.0;
  const RgbaImage pair = render_volume(sphere, nullptr, config);
  ASSERT_EQ(pair.width, 64u);
  config.view.stereo = false;
  for (const int eye : {0, 1}) {
    config.view.azimuth_deg = 20.0 + (eye == 0 ? -4.5 : 4.5);
    const RgbaImage mono = render_volume(sphere, nullptr, config);
    for (std::uint32_t y = 0; y < 24; ++y) {
      for (std::uint32_t x = 0; x < 32; ++x) {
        for (int c = 0; c < 4; ++c) {
          ASSERT_NEAR(pair.pixel(x + 32 * eye, y)[c], mono.pixel(x, y)[c], 1)
              << "eye " << eye << " at " << x << "," << y;
        }
      }
    }
  }
}

TEST(Slices, ShowTheVoxelsOfTheChosenBscan) {
  Volume volume(4, 16, 16);
  for (std::uint32_t b = 0; b < 4; ++b) {
    std::fill(volume.bscan(b).begin(), volume.bscan(b).end(),
              static_cast<std::uint8_t>(50 * b + 20));
  }
  RenderConfig config = isotropic(32, 32);
  config.mode = RenderMode::bscan_slice;
  config.slice.bscan = 2;
  const RgbaImage image = render_volume(volume, nullptr, config);
  EXPECT_EQ(image.pixel(16, 16)[0], 120);
  config.slice.bscan = 4;
  EXPECT_THROW(render_volume(volume, nullptr, config), ioct::ConfigError);
}

TEST(Renderer, RefusesEmptyVolumesAndRenderingBeforeAVolume) {
  CpuRenderer renderer(1);
  RgbaImage image;
  EXPECT_THROW(renderer.render(RenderConfig{}, image), std::logic_error);
  EXPECT_THROW(renderer.set_volume(Volume{}, nullptr), std::invalid_argument);
}

TEST(Renderer, UpdatingBscansEqualsSettingTheWholeVolume) {
  Volume before = make_sphere(24, 8.0, 4.0);
  Volume after = make_sphere(24, 10.0, 4.0);
  for (std::uint32_t b = 0; b < 12; ++b) {
    std::copy(before.bscan(b).begin(), before.bscan(b).end(), after.bscan(b).begin());
  }
  RenderConfig config = isotropic(40, 30);
  config.mode = RenderMode::axial_colorization;
  CpuRenderer live(1);
  live.set_volume(before, nullptr);
  live.update_bscans(after, 12, 12, nullptr);
  RgbaImage a, b;
  live.render(config, a);
  CpuRenderer whole(1);
  whole.set_volume(after, nullptr);
  whole.render(config, b);
  EXPECT_EQ(a.rgba, b.rgba);
  EXPECT_THROW(live.update_bscans(after, 20, 8, nullptr), std::out_of_range);
}

}  // namespace
