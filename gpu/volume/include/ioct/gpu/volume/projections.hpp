// 2-D views of a volume for quick looks and files: one B-scan, and the en face projection.
#pragma once

#include <cstdint>
#include <string_view>

#include "ioct/gpu/volume/gray_image.hpp"
#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu {

// B-scan `bscan` with depth vertical (row = depth, top = zero delay) and A-scans horizontal.
GrayImage bscan_image(const Volume& volume, std::uint32_t bscan);

enum class EnfaceProjection {
  mean,  // the mean along depth, stretched so its darkest pixel is 0 and its brightest 255
  max,   // the maximum along depth, unstretched
};

std::string_view to_string(EnfaceProjection projection) noexcept;
// Throws ConfigError("enface", ...) naming the accepted values.
EnfaceProjection parse_enface_projection(std::string_view text);

// Projection along depth: B-scans vertical (row = B-scan), A-scans horizontal.
GrayImage enface_image(const Volume& volume, EnfaceProjection projection);

// How much of a volume the dB range clips: the fractions of pixels at 0 (below db_min) and at
// 255 (above db_max), for tuning the range.
struct ClippedFractions {
  double zero = 0.0;
  double saturated = 0.0;
};
ClippedFractions clipped_fractions(const Volume& volume);

}  // namespace ioct::gpu
