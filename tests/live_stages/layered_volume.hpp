// A retina-like test volume for the live stages: speckled layers, a bright band (the "RPE")
// under a dimmer one, on noise, slowly curving.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::live {

inline Volume layered_volume(std::uint32_t bscans, std::uint32_t ascans, std::uint32_t depth,
                             std::uint32_t seed) {
  Volume v(bscans, ascans, depth);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(0, 40);
  for (std::uint32_t b = 0; b < bscans; ++b) {
    for (std::uint32_t a = 0; a < ascans; ++a) {
      const int ilm = static_cast<int>(depth / 3 + 10 * std::sin(a * 0.02 + b * 0.05));
      for (std::uint32_t d = 0; d < depth; ++d) {
        int value = noise(rng);
        const int z = static_cast<int>(d);
        if (z >= ilm && z < ilm + 40) value += 110;
        if (z >= ilm + 40 && z < ilm + 48) value += 200;
        v.bscan(b)[std::size_t{a} * depth + d] = static_cast<std::uint8_t>(std::min(value, 255));
      }
    }
  }
  return v;
}

}  // namespace ioct::gpu::live
