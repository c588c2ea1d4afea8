#include "ioct/gpu/render/png_rgba.hpp"

#include <png.h>

#include <csetjmp>
#include <stdexcept>
#include <string>
#include <vector>

#include "ioct/common/atomic_file.hpp"

namespace ioct::gpu::render {

void write_png(const std::filesystem::path& path, const RgbaImage& image) {
  if (image.width == 0 || image.height == 0 ||
      image.rgba.size() != std::size_t{image.width} * image.height * 4) {
    throw std::runtime_error(path.string() + ": image of " + std::to_string(image.width) + " x " +
                             std::to_string(image.height) + " px has " +
                             std::to_string(image.rgba.size()) + " bytes");
  }
  AtomicFile file(path);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  if (png == nullptr || info == nullptr) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error(path.string() + ": libpng could not start");
  }
  std::vector<png_byte> row(std::size_t{image.width} * 3);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error(path.string() + ": libpng failed to write");
  }
  png_init_io(png, file.stream());
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (std::uint32_t y = 0; y < image.height; ++y) {
    const std::uint8_t* src = image.pixel(0, y);
    for (std::uint32_t x = 0; x < image.width; ++x) {
      row[3 * x + 0] = src[4 * x + 0];
      row[3 * x + 1] = src[4 * x + 1];
      row[3 * x + 2] = src[4 * x + 2];
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  file.commit();
}

}  // namespace ioct::gpu::render
