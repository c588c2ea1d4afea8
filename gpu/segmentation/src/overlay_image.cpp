#include "ioct/gpu/segmentation/overlay_image.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "ioct/gpu/volume/png_file.hpp"

namespace ioct::gpu::segmentation {

void mark(RgbImage& image, std::uint32_t x, float depth_px, OverlayColor color) noexcept {
  const long y = overlay_row(depth_px, image.height);
  if (y < 0 || x >= image.width) return;
  image.set(x, static_cast<std::uint32_t>(y), color.r, color.g, color.b);
}

void check_overlay(const VolumeDims& volume, std::uint32_t bscan, std::uint32_t surface_bscans,
                   std::uint32_t surface_ascans) {
  if (bscan >= volume.bscans) {
    throw std::out_of_range("overlay: B-scan " + std::to_string(bscan) + " of a volume of " +
                            std::to_string(volume.bscans));
  }
  if (surface_bscans != volume.bscans || surface_ascans != volume.ascans) {
    throw std::invalid_argument("overlay: surfaces of " + std::to_string(surface_bscans) + " x " +
                                std::to_string(surface_ascans) + " A-scans for a volume of " +
                                std::to_string(volume.bscans) + " x " +
                                std::to_string(volume.ascans));
  }
}

RgbImage make_overlay(const Volume& volume, std::uint32_t bscan, const Surfaces& surfaces) {
  check_overlay(VolumeDims::of(volume), bscan, surfaces.bscans, surfaces.ascans);
  RgbImage image;
  image.width = volume.ascans();
  image.height = volume.depth();
  image.pixels.resize(std::size_t{image.width} * image.height * 3);
  // The B-scan is stored A-scan by A-scan (depth fastest), the image row by row: a transpose, in
  // tiles that keep both sides in the cache (a column at a time strides the image by a whole row
  // per pixel, which made this the slowest step of a live frame with a new B-scan).
  constexpr std::uint32_t kTile = 32;
  const std::uint8_t* grey = volume.bscan(bscan).data();
  for (std::uint32_t a0 = 0; a0 < image.width; a0 += kTile) {
    const std::uint32_t a_end = std::min(a0 + kTile, image.width);
    for (std::uint32_t d0 = 0; d0 < image.height; d0 += kTile) {
      const std::uint32_t d_end = std::min(d0 + kTile, image.height);
      for (std::uint32_t d = d0; d < d_end; ++d) {
        std::uint8_t* out = image.pixels.data() + (std::size_t{d} * image.width + a0) * 3;
        for (std::uint32_t a = a0; a < a_end; ++a, out += 3) {
          const std::uint8_t v = grey[std::size_t{a} * image.height + d];
          out[0] = v;
          out[1] = v;
          out[2] = v;
        }
      }
    }
  }
  for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
    const std::size_t k = surfaces.index(bscan, a);
    if (!overlay_column_marked(surfaces.state[k], a)) continue;
    // In this order: where two lines meet, the later one shows.
    mark(image, a, surfaces.bm[k], kBmColor);
    mark(image, a, surfaces.rpe[k], kRpeColor);
    mark(image, a, surfaces.ilm[k], kIlmColor);
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
