#include "analytic_volumes.hpp"

#include <algorithm>
#include <cmath>

namespace ioct::render_test {

gpu::Volume make_sphere(std::uint32_t n, double radius, double ramp) {
  gpu::Volume v(n, n, n);
  const double c = 0.5 * (n - 1);
  for (std::uint32_t b = 0; b < n; ++b) {
    for (std::uint32_t a = 0; a < n; ++a) {
      for (std::uint32_t d = 0; d < n; ++d) {
        const double r = std::sqrt((a - c) * (a - c) + (b - c) * (b - c) + (d - c) * (d - c));
        const double value = std::clamp(0.5 - (r - radius) / ramp, 0.0, 1.0);
        v.bscan(b)[std::size_t{a} * n + d] = static_cast<std::uint8_t>(std::lround(255.0 * value));
      }
    }
  }
  return v;
}

gpu::Volume make_slabs(std::uint32_t lateral, std::uint32_t depth, const Slab* slabs,
                       std::size_t count) {
  gpu::Volume v(lateral, lateral, depth);
  std::fill(v.pixels().begin(), v.pixels().end(), std::uint8_t{0});
  for (std::uint32_t b = 0; b < lateral; ++b) {
    for (std::uint32_t a = 0; a < lateral; ++a) {
      for (std::size_t s = 0; s < count; ++s) {
        for (std::uint32_t d = slabs[s].begin; d < slabs[s].end && d < depth; ++d) {
          v.bscan(b)[std::size_t{a} * depth + d] = slabs[s].value;
        }
      }
    }
  }
  return v;
}

double curved_layer_depth(std::uint32_t bscan, std::uint32_t ascan, std::uint32_t bscans,
                          std::uint32_t ascans, std::uint32_t depth) {
  const double x = (ascan + 0.5) / ascans - 0.5;
  const double y = (bscan + 0.5) / bscans - 0.5;
  return depth * (0.45 + 0.6 * (x * x + y * y) + 0.08 * x);
}

VolumeWithSurfaces make_curved_layer(std::uint32_t bscans, std::uint32_t ascans,
                                     std::uint32_t depth) {
  VolumeWithSurfaces out;
  out.volume.reshape(bscans, ascans, depth);
  out.surfaces.reset(bscans, ascans, depth);
  for (std::uint32_t b = 0; b < bscans; ++b) {
    for (std::uint32_t a = 0; a < ascans; ++a) {
      const double rpe = curved_layer_depth(b, a, bscans, ascans, depth);
      out.surfaces.rpe[out.surfaces.index(b, a)] = static_cast<float>(rpe);
      out.surfaces.ilm[out.surfaces.index(b, a)] = static_cast<float>(rpe - 20.0);
      out.surfaces.state[out.surfaces.index(b, a)] = gpu::segmentation::SurfaceState::measured;
      for (std::uint32_t d = 0; d < depth; ++d) {
        const double z = std::max(0.0, std::fabs(d - rpe) - 1.0);
        const double value = 30.0 + 220.0 * std::exp(-0.5 * z * z);
        out.volume.bscan(b)[std::size_t{a} * depth + d] =
            static_cast<std::uint8_t>(std::lround(value));
      }
    }
  }
  return out;
}

namespace {

// A deterministic value in [0, 1) per voxel: speckle without a random engine's state.
double hash01(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t seed) {
  std::uint32_t h = a * 0x8da6b343u ^ b * 0xd8163841u ^ c * 0xcb1ab31fu ^ seed * 0x9e3779b9u;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return (h >> 8) * (1.0 / 16777216.0);
}

}  // namespace

VolumeWithSurfaces make_synthetic_retina(std::uint32_t bscans, std::uint32_t ascans,
                                         std::uint32_t depth, std::uint32_t seed) {
  VolumeWithSurfaces out;
  out.volume.reshape(bscans, ascans, depth);
  out.surfaces.reset(bscans, ascans, depth);
  const double thickness = 0.16 * depth;  // ILM to RPE away from the fovea
  for (std::uint32_t b = 0; b < bscans; ++b) {
    for (std::uint32_t a = 0; a < ascans; ++a) {
      const double x = (a + 0.5) / ascans - 0.5;
      const double y = (b + 0.5) / bscans - 0.5;
      const double r2 = x * x + y * y;
      const double rpe = depth * (0.55 + 0.35 * r2);
      const double pit = 0.55 * thickness * std::exp(-r2 / (2 * 0.06 * 0.06));
      const double ilm = rpe - thickness + pit;
      // The needle: a bright cylinder along the A-scan axis direction, above the retina, its
      // shadow darkening what lies beneath.
      const double nx = x - 0.22;
      const double ny = y + 0.1 - 0.3 * x;
      const bool needle_column = std::fabs(nx) < 0.5 && std::fabs(ny) < 0.035 && x > -0.28;
      const double needle_top = ilm - 0.1 * depth - 0.25 * depth * (x + 0.28);
      const std::size_t i = out.surfaces.index(b, a);
      out.surfaces.ilm[i] = static_cast<float>(ilm);
      out.surfaces.rpe[i] = static_cast<float>(rpe);
      out.surfaces.state[i] = gpu::segmentation::SurfaceState::measured;
      for (std::uint32_t d = 0; d < depth; ++d) {
        double value = 8.0;
        const double z = d - ilm;
        if (z >= 0.0) {
          const double rel = z / (rpe - ilm);
          if (rel < 0.12)
            value = 170.0;  // nerve fibre layer
          else if (rel < 0.55)
            value = 105.0;  // inner layers
          else if (rel < 0.85)
            value = 55.0;  // outer nuclear layer
          else
            value = 120.0;  // photoreceptors
          const double to_rpe = d - rpe;
          value += 140.0 * std::exp(-0.5 * to_rpe * to_rpe / 4.0);
          if (to_rpe > 3.0) value = 130.0 * std::exp(-(to_rpe - 3.0) / (0.12 * depth));
        }
        if (needle_column) {
          const double dz = d - needle_top;
          if (dz >= 0.0 && dz < 0.03 * depth)
            value = 245.0;
          else if (dz >= 0.03 * depth)
            value *= 0.25;  // the needle's shadow
        }
        value *= 0.55 + 0.9 * hash01(a, b, d, seed);
        out.volume.bscan(b)[std::size_t{a} * depth + d] =
            static_cast<std::uint8_t>(std::clamp(std::lround(value), 0L, 255L));
      }
    }
  }
  return out;
}

}  // namespace ioct::render_test
