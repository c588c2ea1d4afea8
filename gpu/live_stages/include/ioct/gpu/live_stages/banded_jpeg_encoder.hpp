// JPEG encoding on several threads, for the renders on the way to the viewers: the image is cut
// into horizontal bands, each band is encoded on its own (JpegEncoder), and the bands are joined
// into one baseline JPEG with a restart marker between them (join_jpeg_bands). A restart resets
// what a band's entropy coding carries over from the one before (the DC predictions), so the
// joined file decodes exactly as one encoded whole; any JPEG decoder reads it (browsers included).
// It costs a few bytes per band.
#pragma once

#include <atomic>
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

  // encode() in three steps, so that the bands of several images can share one run of a pool:
  // cut() takes the image (its pixels must stay valid until joined()) and returns how many bands
  // it is encoded in; encode_band(k) encodes band k, for each k in [0, cut()) once, from any
  // thread; joined() returns the JPEG, valid until the next cut(). Pixels that do not fit the
  // size make encode_band throw, as encode() does; encode_band out of turn, and joined() with
  // nothing cut or not every band encoded once, throw std::logic_error.
  std::uint32_t cut(std::span<const std::uint8_t> pixels, std::uint32_t width, std::uint32_t height,
                    PixelLayout layout);
  void encode_band(std::uint32_t band);
  std::span<const std::byte> joined();

  unsigned bands() const noexcept { return static_cast<unsigned>(encoders_.size()); }

 private:
  // The image being encoded, from cut() to joined().
  struct Cut {
    std::span<const std::uint8_t> pixels;
    std::uint32_t width = 0, height = 0;
    PixelLayout layout = PixelLayout::rgb;
    std::uint32_t band_count = 0;  // 0: none cut
    std::uint32_t rows_per_band = 0;
    std::uint32_t restart_interval = 0;  // MCUs per band
  };

  std::vector<std::unique_ptr<JpegEncoder>> encoders_;  // one per band
  WorkerPool& pool_;
  Cut cut_;
  std::atomic<std::uint32_t> bands_encoded_{0};  // of cut_, counted by encode_band
  std::vector<std::span<const std::byte>> encoded_;
  std::vector<std::byte> joined_;
};

}  // namespace ioct::gpu::live
