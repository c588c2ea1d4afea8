// An 8-bit RGBA image, row-major, top row first: what every renderer produces. Colour is
// composited over the configured background; alpha is the accumulated opacity of the ray.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace ioct::gpu::render {

struct RgbaImage {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::uint8_t> rgba;  // height rows of width pixels, 4 bytes each

  void resize(std::uint32_t w, std::uint32_t h) {
    width = w;
    height = h;
    rgba.assign(std::size_t{w} * h * 4, 0);
  }
  const std::uint8_t* pixel(std::uint32_t x, std::uint32_t y) const noexcept {
    return rgba.data() + (std::size_t{y} * width + x) * 4;
  }
};

}  // namespace ioct::gpu::render
