#include "ioct/gpu/live_stages/jpeg_encoder.hpp"

#include <turbojpeg.h>

#include <stdexcept>
#include <string>

namespace ioct::gpu::live {
namespace {

struct Format {
  int pixel_format;
  int subsampling;
  std::size_t bytes_per_pixel;
};

Format format_of(PixelLayout layout) {
  switch (layout) {
    case PixelLayout::rgba:
      return {TJPF_RGBA, TJSAMP_420, 4};
    case PixelLayout::rgb:
      return {TJPF_RGB, TJSAMP_420, 3};
    case PixelLayout::gray:
      return {TJPF_GRAY, TJSAMP_GRAY, 1};
  }
  throw std::invalid_argument("unknown pixel layout");
}

}  // namespace

McuSize mcu_size(PixelLayout layout) {
  const int sampling = format_of(layout).subsampling;
  return {static_cast<std::uint32_t>(tjMCUWidth[sampling]),
          static_cast<std::uint32_t>(tjMCUHeight[sampling])};
}

JpegEncoder::JpegEncoder(int quality) : quality_(quality) {
  if (quality < 1 || quality > 100) {
    throw std::invalid_argument("JPEG quality " + std::to_string(quality) + " must be in [1, 100]");
  }
  handle_ = tjInitCompress();
  if (handle_ == nullptr) {
    throw std::runtime_error(std::string("cannot start the JPEG encoder: ") +
                             tjGetErrorStr2(nullptr));
  }
}

JpegEncoder::~JpegEncoder() {
  if (handle_ != nullptr) tjDestroy(handle_);
}

std::span<const std::byte> JpegEncoder::encode(std::span<const std::uint8_t> pixels,
                                               std::uint32_t width, std::uint32_t height,
                                               PixelLayout layout) {
  const Format format = format_of(layout);
  if (width == 0 || height == 0 || width > 65535 || height > 65535 ||
      pixels.size() != std::size_t{width} * height * format.bytes_per_pixel) {
    throw std::invalid_argument("JPEG input of " + std::to_string(pixels.size()) +
                                " bytes does not fit " + std::to_string(width) + "x" +
                                std::to_string(height) + " pixels");
  }
  // The worst case for this size, so the library never reallocates the buffer itself.
  const unsigned long bound =
      tjBufSize(static_cast<int>(width), static_cast<int>(height), format.subsampling);
  if (buffer_.size() < bound) buffer_.resize(bound);
  unsigned char* out = buffer_.data();
  unsigned long size = bound;
  const int rc = tjCompress2(handle_, pixels.data(), static_cast<int>(width), 0,
                             static_cast<int>(height), format.pixel_format, &out, &size,
                             format.subsampling, quality_, TJFLAG_NOREALLOC | TJFLAG_FASTDCT);
  if (rc != 0) {
    throw std::runtime_error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(handle_));
  }
  return std::as_bytes(std::span<const unsigned char>(buffer_.data(), size));
}

}  // namespace ioct::gpu::live
