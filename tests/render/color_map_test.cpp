// The L*a*b* colour map: the conversion against published sRGB values and the map's stated
// properties (Weiss et al. 2019, Sec. 3.1).
#include <gtest/gtest.h>

#include <cmath>

#include "ioct/gpu/render/lab_color.hpp"
#include "ioct/gpu/render/pixel_shader.hpp"

namespace {

using namespace ioct::gpu::render;

void expect_srgb8(double l, double a, double b, int r8, int g8, int b8) {
  const auto rgb = lab_to_srgb(l, a, b);
  EXPECT_NEAR(rgb[0] * 255.0, r8, 0.6) << "L*a*b* " << l << " " << a << " " << b;
  EXPECT_NEAR(rgb[1] * 255.0, g8, 0.6) << "L*a*b* " << l << " " << a << " " << b;
  EXPECT_NEAR(rgb[2] * 255.0, b8, 0.6) << "L*a*b* " << l << " " << a << " " << b;
}

TEST(LabToSrgb, MatchesPublishedValues) {
  // Neutral greys (CIE L* to sRGB through the D65 white): L* 50 is sRGB 119.
  expect_srgb8(50.0, 0.0, 0.0, 119, 119, 119);
  expect_srgb8(100.0, 0.0, 0.0, 255, 255, 255);
  expect_srgb8(0.0, 0.0, 0.0, 0, 0, 0);
  expect_srgb8(53.585, 0.0, 0.0, 128, 128, 128);
  // The sRGB primaries (their L*a*b* as Lindbloom's calculator and CSS Color 4 give them).
  expect_srgb8(53.2408, 80.0925, 67.2032, 255, 0, 0);
  expect_srgb8(87.7347, -86.1827, 83.1793, 0, 255, 0);
  expect_srgb8(32.2970, 79.1875, -107.8602, 0, 0, 255);
  expect_srgb8(97.1393, -21.5537, 94.4780, 255, 255, 0);
}

TEST(LabToSrgb, ClampsOutOfGamutColours) {
  const auto rgb = lab_to_srgb(50.0, 120.0, 120.0);
  for (const double c : rgb) {
    EXPECT_GE(c, 0.0);
    EXPECT_LE(c, 1.0);
  }
}

TEST(ChromaScale, HasTheStatedShape) {
  EXPECT_DOUBLE_EQ(chroma_scale(ChromaCurve::stated_properties, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(chroma_scale(ChromaCurve::stated_properties, 0.0), 0.0);
  EXPECT_DOUBLE_EQ(chroma_scale(ChromaCurve::stated_properties, 1.0), 0.0);
  EXPECT_DOUBLE_EQ(chroma_scale(ChromaCurve::as_printed, 0.0), 0.75);
  EXPECT_DOUBLE_EQ(chroma_scale(ChromaCurve::as_printed, 0.5), 1.0);
}

TEST(LayerColorMap, SeparatesIntensityFromDepth) {
  const LabColorMap map;
  // Luminance is the intensity alone; depth moves only the chroma.
  const auto shallow = layer_color_lab(map, 0.5, 0.0);
  const auto deep = layer_color_lab(map, 0.5, 1.0);
  EXPECT_DOUBLE_EQ(shallow[0], 50.0);
  EXPECT_DOUBLE_EQ(deep[0], 50.0);
  EXPECT_DOUBLE_EQ(shallow[1], -50.0);
  EXPECT_DOUBLE_EQ(shallow[2], -50.0);
  EXPECT_DOUBLE_EQ(deep[1], 75.0);
  EXPECT_DOUBLE_EQ(deep[2], 75.0);
  const auto rgb_shallow = lab_to_srgb(shallow[0], shallow[1], shallow[2]);
  const auto rgb_deep = lab_to_srgb(deep[0], deep[1], deep[2]);
  EXPECT_GT(rgb_shallow[2], rgb_shallow[0]);  // blue above the RPE
  EXPECT_GT(rgb_deep[0], rgb_deep[2]);        // red below it
  // No chroma at the ends of the intensity range.
  EXPECT_DOUBLE_EQ(layer_color_lab(map, 1.0, 0.7)[1], 0.0);
}

TEST(LayerColorMap, DeltaStarSpansOneThicknessAboveToTwoBelow) {
  EXPECT_FLOAT_EQ(delta_star(100.0f, 150.0f, 50.0f), 0.0f);
  EXPECT_FLOAT_EQ(delta_star(150.0f, 150.0f, 50.0f), 1.0f / 3.0f);
  EXPECT_FLOAT_EQ(delta_star(250.0f, 150.0f, 50.0f), 1.0f);
  EXPECT_FLOAT_EQ(delta_star(0.0f, 150.0f, 50.0f), 0.0f);
  EXPECT_FLOAT_EQ(delta_star(400.0f, 150.0f, 50.0f), 1.0f);
}

TEST(LabLut, HoldsTheExactConversionAtItsNodes) {
  const LabColorMap map;
  const auto lut = bake_lab_lut(map, true);
  for (const int i : {0, 37, 128, 200, 255}) {
    for (const int j : {0, 85, 255}) {
      const double intensity = i / 255.0;
      const double ds = j / 255.0;
      const auto lab = layer_color_lab(map, intensity, ds);
      const auto rgb = lab_to_srgb(lab[0], lab[1], lab[2]);
      const Vec3 got =
          lab_lookup(lut.data(), static_cast<float>(intensity), static_cast<float>(ds));
      EXPECT_NEAR(got.x, rgb[0], 1e-5);
      EXPECT_NEAR(got.y, rgb[1], 1e-5);
      EXPECT_NEAR(got.z, rgb[2], 1e-5);
    }
  }
  // Between the nodes the bilinear table stays within half an 8-bit level of the exact map.
  double worst = 0.0;
  for (double intensity = 0.0013; intensity < 1.0; intensity += 0.0371) {
    for (double ds = 0.0021; ds < 1.0; ds += 0.0573) {
      const auto lab = layer_color_lab(map, intensity, ds);
      const auto rgb = lab_to_srgb(lab[0], lab[1], lab[2]);
      const Vec3 got =
          lab_lookup(lut.data(), static_cast<float>(intensity), static_cast<float>(ds));
      worst = std::max(
          {worst, std::fabs(got.x - rgb[0]), std::fabs(got.y - rgb[1]), std::fabs(got.z - rgb[2])});
    }
  }
  EXPECT_LT(worst * 255.0, 0.5);
}

TEST(LabLut, WithoutColourIsGrey) {
  const auto lut = bake_lab_lut(LabColorMap{}, false);
  const Vec3 c = lab_lookup(lut.data(), 0.5f, 0.9f);
  EXPECT_NEAR(c.x * 255.0, 119.0, 0.6);
  EXPECT_FLOAT_EQ(c.x, c.y);
  EXPECT_FLOAT_EQ(c.y, c.z);
}

TEST(TransferLut, InterpolatesThePoints) {
  TransferFunctions t;
  t.color = {{0.2, {0.0, 0.5, 1.0}}, {0.6, {1.0, 0.5, 0.0}}};
  t.opacity = {{0.5, 0.0}, {1.0, 0.8}};
  const auto lut = bake_transfer_lut(t);
  const Rgba below = transfer_lookup(lut.data(), 0.0f);
  EXPECT_FLOAT_EQ(below.r, 0.0f);
  EXPECT_FLOAT_EQ(below.a, 0.0f);
  const Rgba mid = transfer_lookup(lut.data(), 0.4f);
  EXPECT_NEAR(mid.r, 0.5f, 0.01f);
  EXPECT_NEAR(mid.b, 0.5f, 0.01f);
  const Rgba top = transfer_lookup(lut.data(), 1.0f);
  EXPECT_FLOAT_EQ(top.a, 0.8f);
  EXPECT_NEAR(transfer_lookup(lut.data(), 0.75f).a, 0.4f, 0.005f);
}

TEST(TransferLut, TheWindowStretchesItsRangeOverTheFunctions) {
  TransferFunctions t;
  t.opacity = {{0.0, 0.0}, {1.0, 1.0}};
  t.window = {0.25, 0.75};
  const auto lut = bake_transfer_lut(t);
  EXPECT_FLOAT_EQ(transfer_lookup(lut.data(), 0.2f).a, 0.0f);     // below the window: its start
  EXPECT_NEAR(transfer_lookup(lut.data(), 0.5f).a, 0.5f, 0.01f);  // its middle: the ramp's
  EXPECT_FLOAT_EQ(transfer_lookup(lut.data(), 0.8f).a, 1.0f);     // above: its end
}

}  // namespace
