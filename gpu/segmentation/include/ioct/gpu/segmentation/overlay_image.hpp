// A B-scan with its surfaces drawn over it, as an RGB PNG: the offline command's picture of what
// the segmentation found, and the tests' view of a failure.
//
// The B-scan in grey (depth down, A-scans across), the ILM in red, the RPE centre in green, the
// Bruch's membrane in blue; bridged A-scans (instrument shadow) are drawn every
// other A-scan, so their line shows dotted; a B-scan without a retina has no lines.
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "ioct/gpu/cuda/host_device_function.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::segmentation {

// What the overlay draws, for make_overlay and its CUDA sibling (cuda_overlay_image.hpp) alike.
struct OverlayColor {
  std::uint8_t r, g, b;
};
inline constexpr OverlayColor kIlmColor{255, 40, 40};
inline constexpr OverlayColor kRpeColor{0, 230, 0};
inline constexpr OverlayColor kBmColor{40, 120, 255};

// The row of a mark at depth `depth_px` (rounded half away from zero) in an image `height` rows
// high; -1: none (NaN, or off the image).
IOCT_HD long overlay_row(float depth_px, std::uint32_t height) {
#if defined(__CUDA_ARCH__)
  if (!isfinite(depth_px)) return -1;
  const long row = lroundf(depth_px);
#else
  if (!std::isfinite(depth_px)) return -1;
  const long row = std::lround(depth_px);
#endif
  return row >= 0 && row < static_cast<long>(height) ? row : -1;
}

// Whether column `ascan` carries its marks: bridged A-scans only every other one, so that an
// inferred line shows dotted.
IOCT_HD bool overlay_column_marked(SurfaceState state, std::uint32_t ascan) {
  return !(state == SurfaceState::bridged && ascan % 2 == 1);
}

struct RgbImage {
  std::uint32_t width = 0;
  std::uint32_t height = 0;
  std::vector<std::uint8_t> pixels;  // height rows of width x (r, g, b)

  void set(std::uint32_t x, std::uint32_t y, std::uint8_t r, std::uint8_t g,
           std::uint8_t b) noexcept {
    std::uint8_t* p = pixels.data() + (std::size_t{y} * width + x) * 3;
    p[0] = r;
    p[1] = g;
    p[2] = b;
  }
};

// B-scan `bscan` of `volume` with its surfaces. Throws std::out_of_range for a B-scan outside the
// volume and std::invalid_argument when the surfaces have other dimensions.
RgbImage make_overlay(const Volume& volume, std::uint32_t bscan, const Surfaces& surfaces);

// make_overlay's checks, for it and its CUDA sibling: the volume's size against the B-scan asked
// for and the surfaces' size. Throws as make_overlay does.
void check_overlay(const VolumeDims& volume, std::uint32_t bscan, std::uint32_t surface_bscans,
                   std::uint32_t surface_ascans);

// A mark at depth `depth_px` (rounded) of column `x`; nothing when it is NaN or off the image.
void mark(RgbImage& image, std::uint32_t x, float depth_px, OverlayColor color) noexcept;

// Rows [first_row, first_row + rows) of `image` (clipped to it).
RgbImage crop_rows(const RgbImage& image, std::uint32_t first_row, std::uint32_t rows);

// Writes an 8-bit RGB PNG that appears complete or not at all. Throws std::runtime_error naming
// the path and the reason.
void write_png_rgb8(const std::filesystem::path& path, const RgbImage& image);

}  // namespace ioct::gpu::segmentation
