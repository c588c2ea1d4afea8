// JPEG encoding of the frames for viewers (libjpeg-turbo's TurboJPEG API): the renders (RGBA) and
// the B-scans (RGB with the surfaces drawn in, or grey). One encoder per thread; the output buffer
// is kept between frames, so steady-state encoding allocates nothing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace ioct::gpu::live {

enum class PixelLayout { rgba, rgb, gray };

// The block the encoder codes a layout in (px): 16 x 16 with the chroma halved both ways (colour),
// 8 x 8 (grey).
struct McuSize {
  std::uint32_t width;
  std::uint32_t height;
};
McuSize mcu_size(PixelLayout layout);

class JpegEncoder {
 public:
  // quality: 1..100 (std::invalid_argument otherwise). Throws std::runtime_error when the library
  // cannot be initialised.
  explicit JpegEncoder(int quality = 85);
  ~JpegEncoder();
  JpegEncoder(const JpegEncoder&) = delete;
  JpegEncoder& operator=(const JpegEncoder&) = delete;

  // Encodes `pixels` (height rows of width pixels, tightly packed). The result stays valid until
  // the next call. Throws std::invalid_argument for a size that does not match, std::runtime_error
  // with the library's message when encoding fails.
  std::span<const std::byte> encode(std::span<const std::uint8_t> pixels, std::uint32_t width,
                                    std::uint32_t height, PixelLayout layout);

 private:
  void* handle_ = nullptr;  // tjhandle
  int quality_;
  std::vector<unsigned char> buffer_;
};

}  // namespace ioct::gpu::live
