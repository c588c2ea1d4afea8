#include "ioct/gpu/volume/projections.hpp"

#include <algorithm>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::gpu {

GrayImage bscan_image(const Volume& volume, std::uint32_t bscan) {
  GrayImage image{volume.ascans(), volume.depth(), {}};
  image.pixels.resize(std::size_t{image.width} * image.height);
  const std::span<const std::uint8_t> source = volume.bscan(bscan);
  for (std::uint32_t a = 0; a < volume.ascans(); ++a) {
    const std::uint8_t* line = source.data() + std::size_t{a} * volume.depth();
    for (std::uint32_t d = 0; d < volume.depth(); ++d) {
      image.pixels[std::size_t{d} * image.width + a] = line[d];
    }
  }
  return image;
}

std::string_view to_string(EnfaceProjection projection) noexcept {
  return projection == EnfaceProjection::mean ? "mean" : "max";
}

EnfaceProjection parse_enface_projection(std::string_view text) {
  if (text == "mean") return EnfaceProjection::mean;
  if (text == "max") return EnfaceProjection::max;
  throw ConfigError("enface", "'" + std::string(text) + "'", "must be mean or max");
}

GrayImage enface_image(const Volume& volume, EnfaceProjection projection) {
  GrayImage image{volume.ascans(), volume.bscans(), {}};
  image.pixels.resize(std::size_t{image.width} * image.height);
  if (volume.depth() == 0) return image;
  std::vector<std::uint32_t> sums(image.pixels.size());
  for (std::uint32_t b = 0; b < volume.bscans(); ++b) {
    const std::uint8_t* line = volume.bscan(b).data();
    for (std::uint32_t a = 0; a < volume.ascans(); ++a, line += volume.depth()) {
      std::uint32_t value = 0;
      if (projection == EnfaceProjection::max) {
        value = *std::max_element(line, line + volume.depth());
      } else {
        for (std::uint32_t d = 0; d < volume.depth(); ++d) value += line[d];
      }
      sums[std::size_t{b} * image.width + a] = value;
    }
  }
  if (projection == EnfaceProjection::max) {
    std::ranges::transform(sums, image.pixels.begin(),
                           [](std::uint32_t v) { return static_cast<std::uint8_t>(v); });  // <= 255
    return image;
  }
  // Most of an A-scan is dark, so the plain mean is dim: stretch its range to 0..255.
  const auto [low, high] = std::ranges::minmax(sums);
  if (high == low) return image;  // flat: all 0
  const std::uint64_t range = high - low;
  for (std::size_t i = 0; i < sums.size(); ++i) {
    image.pixels[i] =
        static_cast<std::uint8_t>((std::uint64_t{sums[i] - low} * 255 + range / 2) / range);
  }
  return image;
}

ClippedFractions clipped_fractions(const Volume& volume) {
  const std::span<const std::uint8_t> pixels = volume.pixels();
  if (pixels.empty()) return {};
  // Per B-scan in 32-bit counters (a B-scan has far fewer than 2^32 pixels), which vectorises.
  std::uint64_t zeros = 0;
  std::uint64_t saturated = 0;
  for (std::uint32_t b = 0; b < volume.bscans(); ++b) {
    const std::span<const std::uint8_t> bscan = volume.bscan(b);
    std::uint32_t z = 0;
    std::uint32_t s = 0;
    for (const std::uint8_t p : bscan) {
      z += p == 0 ? 1u : 0u;
      s += p == 255 ? 1u : 0u;
    }
    zeros += z;
    saturated += s;
  }
  const auto total = static_cast<double>(pixels.size());
  return {static_cast<double>(zeros) / total, static_cast<double>(saturated) / total};
}

}  // namespace ioct::gpu
