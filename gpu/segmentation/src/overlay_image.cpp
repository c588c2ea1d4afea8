#include "ioct/gpu/segmentation/overlay_image.hpp"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "ioct/common/atomic_file.hpp"

namespace ioct::gpu::segmentation {
namespace {

struct PngError {
  char message[256] = "";
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* error = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(error->message, sizeof error->message, "%s", message);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

// libpng longjmps back here on error; the frame holds only trivially destructible locals.
bool encode_rgb(std::FILE* file, const RgbImage& image, PngError& error) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, on_png_error, on_png_warning);
  if (png == nullptr) {
    std::snprintf(error.message, sizeof error.message, "libpng could not start (out of memory)");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, &info);
    std::snprintf(error.message, sizeof error.message, "libpng could not start (out of memory)");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (std::uint32_t y = 0; y < image.height; ++y) {
    png_write_row(png, image.pixels.data() + std::size_t{y} * image.width * 3);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

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
  if (image.pixels.size() != std::size_t{image.width} * image.height * 3 || image.width == 0 ||
      image.height == 0) {
    throw std::invalid_argument("write_png_rgb8: " + path.string() + ": an image of " +
                                std::to_string(image.width) + " x " + std::to_string(image.height) +
                                " px with " + std::to_string(image.pixels.size()) + " bytes");
  }
  AtomicFile file(path);
  PngError error;
  if (!encode_rgb(file.stream(), image, error)) {
    throw std::runtime_error("cannot write " + path.string() + ": " + error.message);
  }
  file.commit();
}

}  // namespace ioct::gpu::segmentation
