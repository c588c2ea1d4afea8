#include "ioct/gpu/segmentation/overlay_image.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ioct/gpu/volume/png_file.hpp"

namespace ioct::gpu::segmentation {

void mark(RgbImage& image, std::uint32_t x, float depth_px, std::uint8_t r, std::uint8_t g,
          std::uint8_t b) noexcept {
  if (!std::isfinite(depth_px) || x >= image.width) return;
  const long y = std::lround(depth_px);
  if (y < 0 || y >= static_cast<long>(image.height)) return;
  image.set(x, static_cast<std::uint32_t>(y), r, g, b);
}

RgbImage make_overlay(const Volume& volume, std::uint32_t bscan, const Surfaces& surfaces) {
  if (bscan >= volume.bscans()) {
    throw std::out_of_range("overlay: B-scan " + std::to_string(bscan) + " of a volume of " +
                            std::to_string(volume.bscans()));
  }
  if (surfaces.bscans != volume.bscans() || surfaces.ascans != volume.ascans()) {
    throw std::invalid_argument("overlay: surfaces of " + std::to_string(surfaces.bscans) + " x " +
                                std::to_string(surfaces.ascans) + " A-scans for a volume of " +
                                std::to_string(volume.bscans()) + " x " +
                                std::to_string(volume.ascans()));
  }
  RgbImage image;
  image.width = volume.ascans();
  image.height = volume.depth();
  image.pixels.resize(std::size_t{image.width} * image.height * 3);
  for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
    for (std::uint32_t d = 0; d < volume.depth(); ++d) {
      const std::uint8_t v = volume.at(bscan, a, d);
      image.set(a, d, v, v, v);
    }
  }
  for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
    const std::size_t k = surfaces.index(bscan, a);
    if (surfaces.state[k] == SurfaceState::bridged && a % 2 == 1) continue;
    mark(image, a, surfaces.bm[k], 40, 120, 255);
    mark(image, a, surfaces.rpe[k], 0, 230, 0);
    mark(image, a, surfaces.ilm[k], 255, 40, 40);
  }
  return image;
}

RgbImage crop_rows(const RgbImage& image, std::uint32_t first_row, std::uint32_t rows) {
  RgbImage out;
  out.width = image.width;
  const std::uint32_t first = std::min(first_row, image.height);
  out.height = std::min(rows, image.height - first);
  const std::size_t row_bytes = std::size_t{image.width} * 3;
  out.pixels.assign(
      image.pixels.begin() + static_cast<std::ptrdiff_t>(first * row_bytes),
      image.pixels.begin() + static_cast<std::ptrdiff_t>((first + out.height) * row_bytes));
  return out;
}

void write_png_rgb8(const std::filesystem::path& path, const RgbImage& image) {
  write_png8(path, image.width, image.height, 3, image.pixels);
}

}  // namespace ioct::gpu::segmentation
