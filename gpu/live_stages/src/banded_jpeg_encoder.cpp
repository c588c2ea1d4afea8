#include "ioct/gpu/live_stages/banded_jpeg_encoder.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

namespace ioct::gpu::live {
namespace {

constexpr std::byte kMarker{0xff};
constexpr std::uint8_t kSoi = 0xd8;
constexpr std::uint8_t kEoi = 0xd9;
constexpr std::uint8_t kSos = 0xda;
constexpr std::uint8_t kDri = 0xdd;
constexpr std::uint8_t kRst0 = 0xd0;

// Where the parts of one band's JPEG lie.
struct BandLayout {
  std::size_t height_at = 0;  // the frame header's 2 height bytes
  std::size_t scan_at = 0;    // the scan header (FF DA)
  std::size_t data_at = 0;    // the entropy-coded data, after the scan header
  std::size_t data_end = 0;   // its end: the final FF D9
};

std::uint8_t at(std::span<const std::byte> b, std::size_t i) {
  return std::to_integer<std::uint8_t>(b[i]);
}

[[noreturn]] void refuse(std::size_t band, const std::string& why) {
  throw std::invalid_argument("JPEG band " + std::to_string(band) + ": " + why);
}

BandLayout parse_band(std::span<const std::byte> b, std::size_t band) {
  if (b.size() < 4 || at(b, 0) != 0xff || at(b, 1) != kSoi || at(b, b.size() - 2) != 0xff ||
      at(b, b.size() - 1) != kEoi) {
    refuse(band, "not a whole JPEG (SOI ... EOI)");
  }
  BandLayout l;
  l.data_end = b.size() - 2;
  std::size_t i = 2;
  while (i + 4 <= l.data_end) {
    if (b[i] != kMarker) refuse(band, "no marker at offset " + std::to_string(i));
    const std::uint8_t marker = at(b, i + 1);
    const std::size_t length = std::size_t{at(b, i + 2)} << 8 | at(b, i + 3);
    if (length < 2 || i + 2 + length > l.data_end) {
      refuse(band, "segment at offset " + std::to_string(i) + " runs past the end");
    }
    // Start-of-frame markers (C0..CF but C4 DHT, C8 JPG, CC DAC): precision, then the height.
    if (marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc) {
      if (length < 7) refuse(band, "frame header too short");
      l.height_at = i + 5;
    }
    if (marker == kSos) {
      l.scan_at = i;
      l.data_at = i + 2 + length;
      break;
    }
    i += 2 + length;
  }
  if (l.height_at == 0 || l.scan_at == 0) refuse(band, "no frame or scan header");
  return l;
}

}  // namespace

void join_jpeg_bands(std::span<const std::span<const std::byte>> bands, std::uint32_t height,
                     std::uint32_t restart_interval_mcus, std::vector<std::byte>& out) {
  if (bands.empty()) throw std::invalid_argument("JPEG bands: none to join");
  if (height == 0 || height > 65535 || restart_interval_mcus == 0 ||
      restart_interval_mcus > 65535) {
    throw std::invalid_argument("JPEG bands: height " + std::to_string(height) +
                                " or restart interval " + std::to_string(restart_interval_mcus) +
                                " out of range");
  }
  std::vector<BandLayout> layouts;
  layouts.reserve(bands.size());
  for (std::size_t k = 0; k < bands.size(); ++k) layouts.push_back(parse_band(bands[k], k));
  // Every band must code with the first one's tables: the same headers but for the height.
  const std::span<const std::byte> first = bands[0];
  const BandLayout& f = layouts[0];
  for (std::size_t k = 1; k < bands.size(); ++k) {
    const BandLayout& l = layouts[k];
    const std::span<const std::byte> b = bands[k];
    const bool same =
        l.data_at == f.data_at && l.height_at == f.height_at &&
        std::equal(b.begin(), b.begin() + static_cast<long>(l.height_at), first.begin()) &&
        std::equal(b.begin() + static_cast<long>(l.height_at + 2),
                   b.begin() + static_cast<long>(l.data_at),
                   first.begin() + static_cast<long>(f.height_at + 2));
    if (!same) refuse(k, "its headers differ from band 0's (another size, quality or sampling)");
  }

  out.clear();
  out.insert(out.end(), first.begin(), first.begin() + static_cast<long>(f.scan_at));
  out[f.height_at] = std::byte{static_cast<std::uint8_t>(height >> 8)};
  out[f.height_at + 1] = std::byte{static_cast<std::uint8_t>(height & 0xff)};
  const std::byte restart[] = {kMarker,
                               std::byte{kDri},
                               std::byte{0},
                               std::byte{4},
                               std::byte{static_cast<std::uint8_t>(restart_interval_mcus >> 8)},
                               std::byte{static_cast<std::uint8_t>(restart_interval_mcus & 0xff)}};
  out.insert(out.end(), std::begin(restart), std::end(restart));
  out.insert(out.end(), first.begin() + static_cast<long>(f.scan_at),
             first.begin() + static_cast<long>(f.data_at));
  for (std::size_t k = 0; k < bands.size(); ++k) {
    if (k > 0) {
      out.push_back(kMarker);
      out.push_back(std::byte{static_cast<std::uint8_t>(kRst0 + (k - 1) % 8)});
    }
    out.insert(out.end(), bands[k].begin() + static_cast<long>(layouts[k].data_at),
               bands[k].begin() + static_cast<long>(layouts[k].data_end));
  }
  out.push_back(kMarker);
  out.push_back(std::byte{kEoi});
}

BandedJpegEncoder::BandedJpegEncoder(int quality, unsigned bands, WorkerPool& pool) : pool_(pool) {
  if (bands == 0) throw std::invalid_argument("JPEG encoding: 0 bands");
  for (unsigned k = 0; k < bands; ++k) encoders_.push_back(std::make_unique<JpegEncoder>(quality));
  encoded_.resize(bands);
}

std::span<const std::byte> BandedJpegEncoder::encode(std::span<const std::uint8_t> pixels,
                                                     std::uint32_t width, std::uint32_t height,
                                                     PixelLayout layout) {
  pool_.run(cut(pixels, width, height, layout),  // one band: on this thread
            [&](std::uint32_t k, unsigned) { encode_band(k); });
  return joined();
}

std::uint32_t BandedJpegEncoder::cut(std::span<const std::uint8_t> pixels, std::uint32_t width,
                                     std::uint32_t height, PixelLayout layout) {
  const McuSize mcu = mcu_size(layout);
  const std::uint32_t mcu_rows = (height + mcu.height - 1) / mcu.height;
  const std::uint32_t rows_per_band =
      (mcu_rows + bands() - 1) / bands() * mcu.height;  // whole MCU rows
  const std::uint32_t band_count = height == 0 ? 1 : (height + rows_per_band - 1) / rows_per_band;
  const std::uint64_t interval =
      std::uint64_t{rows_per_band / mcu.height} * ((width + mcu.width - 1) / mcu.width);
  cut_ = Cut{pixels,
             width,
             height,
             layout,
             band_count,
             rows_per_band,
             static_cast<std::uint32_t>(interval)};
  bands_encoded_.store(0, std::memory_order_relaxed);
  if (band_count <= 1 || interval > 65535 || height == 0 || pixels.size() % height != 0) {
    cut_.band_count = 1;  // encoded whole: JpegEncoder checks the size
    cut_.rows_per_band = height;
  }
  return cut_.band_count;
}

void BandedJpegEncoder::encode_band(std::uint32_t band) {
  if (band >= cut_.band_count) {
    throw std::logic_error("JPEG band " + std::to_string(band) + " of " +
                           std::to_string(cut_.band_count) + " cut");
  }
  if (cut_.band_count == 1) {
    encoded_[0] = encoders_[0]->encode(cut_.pixels, cut_.width, cut_.height, cut_.layout);
    bands_encoded_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::size_t row_bytes = cut_.pixels.size() / cut_.height;
  const std::uint32_t first = band * cut_.rows_per_band;
  const std::uint32_t rows = std::min(cut_.rows_per_band, cut_.height - first);
  encoded_[band] = encoders_[band]->encode(cut_.pixels.subspan(first * row_bytes, rows * row_bytes),
                                           cut_.width, rows, cut_.layout);
  bands_encoded_.fetch_add(1, std::memory_order_relaxed);
}

std::span<const std::byte> BandedJpegEncoder::joined() {
  if (cut_.band_count == 0) throw std::logic_error("JPEG bands joined before an image was cut");
  // Whoever ran the bands returned before this (a pool's run, say), so the count is complete.
  const std::uint32_t encoded = bands_encoded_.exchange(0, std::memory_order_relaxed);
  const std::uint32_t band_count = std::exchange(cut_.band_count, 0);
  if (encoded != band_count) {
    throw std::logic_error("JPEG bands joined after " + std::to_string(encoded) + " of " +
                           std::to_string(band_count) + " were encoded");
  }
  if (band_count == 1) return encoded_[0];
  join_jpeg_bands(std::span(encoded_.data(), band_count), cut_.height, cut_.restart_interval,
                  joined_);
  return joined_;
}

}  // namespace ioct::gpu::live
