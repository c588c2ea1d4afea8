// Volumes and brute-force references for the filter tests: the definitions of the filters written
// the slow, obvious way.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include "ioct/gpu/filters/gaussian_taps.hpp"
#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::filters::testing {

// Uniform random pixels; with `levels` < 256 only that many distinct values (many ties).
inline Volume random_volume(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth,
                            std::uint32_t seed, std::uint32_t levels = 256) {
  Volume volume(bscans, ascans, depth);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::uint32_t> pick(0, levels - 1);
  for (std::uint32_t b = 0; b < bscans; ++b) {
    for (std::uint8_t& pixel : volume.bscan(b)) {
      pixel = static_cast<std::uint8_t>(levels == 256 ? pick(rng) : pick(rng) * 255 / (levels - 1));
    }
  }
  return volume;
}

inline std::uint32_t clamp_index(std::int64_t i, std::uint32_t size) {
  return static_cast<std::uint32_t>(std::clamp<std::int64_t>(i, 0, std::int64_t{size} - 1));
}

// The median of the 27 clamped neighbours, by sorting them.
inline std::uint8_t brute_force_median(const Volume& in, std::uint32_t b, std::uint32_t a,
                                       std::uint32_t d) {
  std::array<std::uint8_t, 27> values{};
  int n = 0;
  for (int db = -1; db <= 1; ++db) {
    for (int da = -1; da <= 1; ++da) {
      for (int dd = -1; dd <= 1; ++dd) {
        values[n++] = in.at(clamp_index(std::int64_t{b} + db, in.bscans()),
                            clamp_index(std::int64_t{a} + da, in.ascans()),
                            clamp_index(std::int64_t{d} + dd, in.depth()));
      }
    }
  }
  std::sort(values.begin(), values.end());
  return values[13];
}

inline Volume brute_force_median(const Volume& in) {
  Volume out(in.bscans(), in.ascans(), in.depth());
  for (std::uint32_t b = 0; b < in.bscans(); ++b) {
    auto pixels = out.bscan(b);
    for (std::uint32_t a = 0; a < in.ascans(); ++a) {
      for (std::uint32_t d = 0; d < in.depth(); ++d) {
        pixels[std::size_t{a} * in.depth() + d] = brute_force_median(in, b, a, d);
      }
    }
  }
  return out;
}

// The 2-D convolution of one B-scan with the 5x5 outer product of the integer taps, summed
// directly (25 products per pixel), rounded as documented.
inline Volume direct_gaussian(const Volume& in, const GaussianTaps& taps) {
  Volume out(in.bscans(), in.ascans(), in.depth());
  for (std::uint32_t b = 0; b < in.bscans(); ++b) {
    auto pixels = out.bscan(b);
    for (std::uint32_t a = 0; a < in.ascans(); ++a) {
      for (std::uint32_t d = 0; d < in.depth(); ++d) {
        std::uint64_t sum = 0;
        for (int j = -2; j <= 2; ++j) {
          for (int i = -2; i <= 2; ++i) {
            sum += std::uint64_t{taps.taps[j + 2]} * taps.taps[i + 2] *
                   in.at(b, clamp_index(std::int64_t{a} + j, in.ascans()),
                         clamp_index(std::int64_t{d} + i, in.depth()));
          }
        }
        pixels[std::size_t{a} * in.depth() + d] =
            static_cast<std::uint8_t>((sum + (1u << 23)) >> GaussianTaps::kShift);
      }
    }
  }
  return out;
}

// The same convolution with the exact real-valued Gaussian, rounded to nearest.
inline Volume real_gaussian(const Volume& in, const std::array<double, 5>& taps) {
  Volume out(in.bscans(), in.ascans(), in.depth());
  for (std::uint32_t b = 0; b < in.bscans(); ++b) {
    auto pixels = out.bscan(b);
    for (std::uint32_t a = 0; a < in.ascans(); ++a) {
      for (std::uint32_t d = 0; d < in.depth(); ++d) {
        double sum = 0;
        for (int j = -2; j <= 2; ++j) {
          for (int i = -2; i <= 2; ++i) {
            sum += taps[j + 2] * taps[i + 2] *
                   in.at(b, clamp_index(std::int64_t{a} + j, in.ascans()),
                         clamp_index(std::int64_t{d} + i, in.depth()));
          }
        }
        pixels[std::size_t{a} * in.depth() + d] = static_cast<std::uint8_t>(std::lround(sum));
      }
    }
  }
  return out;
}

// Index of the first differing pixel as "(b, a, d): x vs y", or empty when equal.
inline std::string first_difference(const Volume& x, const Volume& y) {
  if (x.bscans() != y.bscans() || x.ascans() != y.ascans() || x.depth() != y.depth()) {
    return "dimensions differ";
  }
  for (std::uint32_t b = 0; b < x.bscans(); ++b) {
    for (std::uint32_t a = 0; a < x.ascans(); ++a) {
      for (std::uint32_t d = 0; d < x.depth(); ++d) {
        if (x.at(b, a, d) != y.at(b, a, d)) {
          return "(" + std::to_string(b) + ", " + std::to_string(a) + ", " + std::to_string(d) +
                 "): " + std::to_string(x.at(b, a, d)) + " vs " + std::to_string(y.at(b, a, d));
        }
      }
    }
  }
  return {};
}

}  // namespace ioct::gpu::filters::testing
