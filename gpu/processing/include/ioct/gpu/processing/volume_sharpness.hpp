// A standard sharpness of a processed (u8) group, to judge a dispersion correction on the image
// the chain actually makes: each pixel back to linear intensity through the dB mapping,
//     I = 10^(dB / 10),   dB = db_min + (db_max - db_min) u8 / 255
// then per A-scan the normalised 4th moment of the amplitude over the rows kept,
//     S = sum_d I_d^2 / (sum_d I_d)^2
// (1 / the number of rows the energy is spread over), averaged over the A-scans. A blurred layer
// spreads its energy over more rows and S falls.
#pragma once

#include <cstdint>
#include <span>

#include "ioct/gpu/processing/db_scale.hpp"
#include "ioct/gpu/volume/processed_group.hpp"

namespace ioct::gpu {

// `kept_rows[d]` != 0 for the rows that count (size: group.depth). 0 when no row is kept.
double volume_sharpness(const ProcessedGroup& group, const DbScaleConfig& scale,
                        std::span<const std::uint8_t> kept_rows);

}  // namespace ioct::gpu
