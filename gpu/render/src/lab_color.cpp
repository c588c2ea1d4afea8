#include "ioct/gpu/render/lab_color.hpp"

#include <algorithm>
#include <cmath>

#include "ioct/gpu/render/render_params.hpp"

namespace ioct::gpu::render {

namespace {

// D65 reference white (CIE 1931 2 deg, normalised to Y = 1).
constexpr double kWhiteX = 0.95047;
constexpr double kWhiteY = 1.0;
constexpr double kWhiteZ = 1.08883;
constexpr double kEpsilon = 216.0 / 24389.0;  // (6/29)^3
constexpr double kKappa = 24389.0 / 27.0;

double lab_f_inverse(double t) {
  const double t3 = t * t * t;
  return t3 > kEpsilon ? t3 : (116.0 * t - 16.0) / kKappa;
}

double srgb_companding(double linear) {
  const double v = std::clamp(linear, 0.0, 1.0);
  return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
}

double interpolate(double x, double x0, double x1, double y0, double y1) {
  return x1 > x0 ? y0 + (y1 - y0) * (x - x0) / (x1 - x0) : y1;
}

}  // namespace

std::array<double, 3> lab_to_srgb(double l_star, double a_star, double b_star) {
  const double fy = (l_star + 16.0) / 116.0;
  const double fx = fy + a_star / 500.0;
  const double fz = fy - b_star / 200.0;
  const double yr = l_star > kKappa * kEpsilon ? fy * fy * fy : l_star / kKappa;
  const double x = lab_f_inverse(fx) * kWhiteX;
  const double y = yr * kWhiteY;
  const double z = lab_f_inverse(fz) * kWhiteZ;
  // XYZ (D65) to linear sRGB, IEC 61966-2-1.
  const double r = 3.2404542 * x - 1.5371385 * y - 0.4985314 * z;
  const double g = -0.9692660 * x + 1.8760108 * y + 0.0415560 * z;
  const double b = 0.0556434 * x - 0.2040259 * y + 1.0572252 * z;
  return {srgb_companding(r), srgb_companding(g), srgb_companding(b)};
}

double chroma_scale(ChromaCurve curve, double intensity) {
  const double d = intensity - 0.5;
  return curve == ChromaCurve::as_printed ? 1.0 - d * d : std::max(0.0, 1.0 - 4.0 * d * d);
}

std::array<double, 3> layer_color_lab(const LabColorMap& map, double intensity, double delta_star) {
  const double g = chroma_scale(map.chroma_curve, intensity) * map.ab_scale;
  const double a = g * (delta_star * map.c1[0] + (1.0 - delta_star) * map.c0[0]);
  const double b = g * (delta_star * map.c1[1] + (1.0 - delta_star) * map.c0[1]);
  return {100.0 * intensity, a, b};
}

std::vector<float> bake_lab_lut(const LabColorMap& map, bool colorize) {
  std::vector<float> lut(std::size_t{kLabLutDepths} * kLabLutIntensities * 4);
  for (int j = 0; j < kLabLutDepths; ++j) {
    const double ds = static_cast<double>(j) / (kLabLutDepths - 1);
    for (int i = 0; i < kLabLutIntensities; ++i) {
      const double intensity = static_cast<double>(i) / (kLabLutIntensities - 1);
      auto lab = layer_color_lab(map, intensity, ds);
      if (!colorize) lab[1] = lab[2] = 0.0;
      const auto rgb = lab_to_srgb(lab[0], lab[1], lab[2]);
      float* out =
          lut.data() + 4 * (std::size_t{static_cast<unsigned>(j)} * kLabLutIntensities + i);
      out[0] = static_cast<float>(rgb[0]);
      out[1] = static_cast<float>(rgb[1]);
      out[2] = static_cast<float>(rgb[2]);
      out[3] = 1.0f;
    }
  }
  return lut;
}

std::vector<float> bake_transfer_lut(const TransferFunctions& transfer) {
  std::vector<float> lut(std::size_t{kTransferLutSize} * 4);
  const double lo = transfer.window[0];
  const double width = transfer.window[1] - transfer.window[0];
  for (int i = 0; i < kTransferLutSize; ++i) {
    const double raw = static_cast<double>(i) / (kTransferLutSize - 1);
    const double v = std::clamp((raw - lo) / width, 0.0, 1.0);
    std::array<double, 3> rgb = transfer.color.front().rgb;
    if (v >= transfer.color.back().intensity) rgb = transfer.color.back().rgb;
    for (std::size_t k = 1; k < transfer.color.size(); ++k) {
      const ColorPoint& p0 = transfer.color[k - 1];
      const ColorPoint& p1 = transfer.color[k];
      if (v >= p0.intensity && v <= p1.intensity) {
        for (int c = 0; c < 3; ++c) {
          rgb[c] = interpolate(v, p0.intensity, p1.intensity, p0.rgb[c], p1.rgb[c]);
        }
        break;
      }
    }
    double alpha = transfer.opacity.front().alpha;
    if (v >= transfer.opacity.back().intensity) alpha = transfer.opacity.back().alpha;
    for (std::size_t k = 1; k < transfer.opacity.size(); ++k) {
      const OpacityPoint& p0 = transfer.opacity[k - 1];
      const OpacityPoint& p1 = transfer.opacity[k];
      if (v >= p0.intensity && v <= p1.intensity) {
        alpha = interpolate(v, p0.intensity, p1.intensity, p0.alpha, p1.alpha);
        break;
      }
    }
    if (v < transfer.opacity.front().intensity) alpha = transfer.opacity.front().alpha;
    for (int c = 0; c < 3; ++c) lut[4 * i + c] = static_cast<float>(rgb[c]);
    lut[4 * i + 3] = static_cast<float>(alpha);
  }
  return lut;
}

}  // namespace ioct::gpu::render
