// An 8-bit grey image, row-major: what the PNG writer takes and the projections make.
#pragma once

#include <cstdint>
#include <vector>

namespace ioct::gpu {

struct GrayImage {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::uint8_t> pixels;  // height rows of width pixels

  std::uint8_t at(std::uint32_t x, std::uint32_t y) const noexcept {
    return pixels[std::size_t{y} * width + x];
  }
};

}  // namespace ioct::gpu
