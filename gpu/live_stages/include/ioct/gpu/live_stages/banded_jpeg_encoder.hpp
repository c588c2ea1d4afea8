// JPEG encoding on several threads, for the renders on the way to the viewers: the image is cut
// into horizontal bands, each band is encoded on its own (JpegEncoder), and the bands are joined
// into one baseline JPEG with a restart marker between them (join_jpeg_bands). A restart resets
// what a band's entropy coding carries over from the one before (the DC predictions), so the
// joined file decodes exactly as one encoded whole; any JPEG decoder reads it (browsers included).
// It costs a few bytes per band.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "ioct/gpu/live_stages/jpeg_encoder.hpp"
#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu::live {

// Joins bands encoded separately (each a whole JPEG of the same width, quality and subsampling,
// every band but the last a whole number of MCU rows high) into one JPEG of `height` rows, with
// a restart interval of `restart_interval_mcus` MCUs (one band's). Throws std::invalid_argument
// when a band is not such a JPEG or the bands' tables differ.
void join_jpeg_bands(std::span<const std::span<const std::byte>> bands, std::uint32_t height,
                     std::uint32_t restart_interval_mcus, std::vector<std::byte>& out);

class BandedJpegEncoder {
 public:
  // bands >= 1 (1: a plain JpegEncoder), encoded on `pool` (which must outlive this; encoders
  // used from one thread may share one); quality as JpegEncoder's. Throws std::invalid_argument
  // for 0 bands.
  BandedJpegEncoder(int quality, unsigned bands, WorkerPool& pool);

  // As JpegEncoder::encode: the result stays valid until the next call. An image too small to
  // cut (fewer MCU rows than bands) is encoded whole.
  std::span<const std::byte> encode(std::span<const std::uint8_t> pixels, std::uint32_t width,
                                    std::uint32_t height, PixelLayout layout);

  unsigned bands() const noexcept { return static_cast<unsigned>(encoders_.size()); }

 private:
  std::vector<std::unique_ptr<JpegEncoder>> encoders_;  // one per band
  WorkerPool& pool_;
  std::vector<std::span<const std::byte>> encoded_;
  std::vector<std::byte> joined_;
};

}  // namespace ioct::gpu::live
