#include "ioct/gpu/volume/png_file.hpp"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>

#include "ioct/common/atomic_file.hpp"
#include "ioct/common/input_file.hpp"

namespace ioct::gpu {
namespace {

// libpng reports errors through a callback that must not return; it longjmps back to the
// setjmp in encode()/decode(), whose frames hold only trivially destructible locals.
struct PngError {
  char message[256] = "";
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* error = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(error->message, sizeof error->message, "%s", message);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

// `channels` bytes per pixel: 1 grey, 3 RGB, 4 RGBA written as RGB (libpng drops the filler).
bool encode(std::FILE* file, std::uint32_t width, std::uint32_t height, int channels,
            const std::uint8_t* pixels, PngError& error) {
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
  if (setjmp(png_jmpbuf(png))) {  // an error inside libpng: on_png_error() filled `error`
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_compression_level(png, 1);  // files are rewritten every volume: speed over size
  png_set_IHDR(png, info, width, height, 8,
               channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (channels == 4) png_set_filler(png, 0, PNG_FILLER_AFTER);
  const std::size_t row_bytes = std::size_t{width} * static_cast<std::size_t>(channels);
  for (std::uint32_t y = 0; y < height; ++y) png_write_row(png, pixels + y * row_bytes);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

bool decode(std::FILE* file, GrayImage& image, PngError& error) {
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &error, on_png_error, on_png_warning);
  if (png == nullptr) {
    std::snprintf(error.message, sizeof error.message, "libpng could not start (out of memory)");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::snprintf(error.message, sizeof error.message, "libpng could not start (out of memory)");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {  // an error inside libpng: on_png_error() filled `error`
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, file);
  png_read_info(png, info);
  const png_byte color_type = png_get_color_type(png, info);
  const png_byte bit_depth = png_get_bit_depth(png, info);
  if (color_type != PNG_COLOR_TYPE_GRAY || bit_depth != 8 ||
      png_get_interlace_type(png, info) != PNG_INTERLACE_NONE) {
    std::snprintf(error.message, sizeof error.message,
                  "not an 8-bit grey non-interlaced PNG (colour type %d, bit depth %d)", color_type,
                  bit_depth);
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  image.width = png_get_image_width(png, info);
  image.height = png_get_image_height(png, info);
  image.pixels.resize(std::size_t{image.width} * image.height);
  for (std::uint32_t y = 0; y < image.height; ++y) {
    png_read_row(png, image.pixels.data() + std::size_t{y} * image.width, nullptr);
  }
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

void write_png8(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                int channels, std::span<const std::uint8_t> pixels) {
  if (channels != 1 && channels != 3 && channels != 4) {
    throw std::invalid_argument("PNG '" + path.string() + "': " + std::to_string(channels) +
                                " bytes per pixel (1, 3 or 4)");
  }
  if (width == 0 || height == 0 ||
      pixels.size() != std::size_t{width} * height * static_cast<std::size_t>(channels)) {
    throw std::invalid_argument("PNG '" + path.string() + "': " + std::to_string(pixels.size()) +
                                " bytes for " + std::to_string(width) + " x " +
                                std::to_string(height) + " px of " + std::to_string(channels));
  }
  AtomicFile file(path);
  PngError error;
  errno = 0;
  if (!encode(file.stream(), width, height, channels, pixels.data(), error)) {
    // libpng says only "Write Error"; the failed fwrite's errno says why (a full disk: ENOSPC).
    const int reason = errno;
    throw std::runtime_error("cannot write PNG '" + path.string() + "': " + error.message +
                             (reason != 0 ? std::string(" (") + std::strerror(reason) + ")" : ""));
  }
  file.commit();
}

GrayImage read_png_gray8(const std::filesystem::path& path) {
  (void)regular_file_size(path.string(), "PNG");  // a FIFO must not block the fopen
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                             &std::fclose);
  if (!file) {
    throw std::runtime_error("cannot open PNG '" + path.string() + "': " + std::strerror(errno));
  }
  GrayImage image;
  PngError error;
  if (!decode(file.get(), image, error)) {
    throw std::runtime_error("cannot read PNG '" + path.string() + "': " + error.message);
  }
  return image;
}

}  // namespace ioct::gpu
