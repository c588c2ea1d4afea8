// 8-bit PNG files through libpng: grey, and colour for the overlays and renders.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>

#include "ioct/gpu/volume/gray_image.hpp"

namespace ioct::gpu {

// Writes `pixels` (height rows of width pixels of `channels` bytes: 1 grey, 3 RGB, 4 RGBA whose
// fourth byte is not written) as an 8-bit PNG. The file appears complete or not at all
// (AtomicFile). Throws std::runtime_error naming the path and the reason, and
// std::invalid_argument when the byte count does not match.
void write_png8(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                int channels, std::span<const std::uint8_t> pixels);

inline void write_png_gray8(const std::filesystem::path& path, std::uint32_t width,
                            std::uint32_t height, std::span<const std::uint8_t> pixels) {
  write_png8(path, width, height, 1, pixels);
}

inline void write_png_gray8(const std::filesystem::path& path, const GrayImage& image) {
  write_png_gray8(path, image.width, image.height, image.pixels);
}

// Reads an 8-bit grey PNG. Throws std::runtime_error naming the path and the reason, also for a
// PNG of another colour type or bit depth.
GrayImage read_png_gray8(const std::filesystem::path& path);

}  // namespace ioct::gpu
