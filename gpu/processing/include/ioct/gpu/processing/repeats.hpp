// Repeated B-scans: with repeats_per_position = R, B-scans R p .. R p + R - 1 of a group are R
// acquisitions of the same position p, and they become one output B-scan whose pixels come from
// the mean power |X|^2 over the R repeats (the mean of powers, then the log, so noise and speckle
// average the way intensity does). A repeat recorded right to left is flipped before it is
// averaged, so bidirectional repeats line up.
//
// The markers of the repeats carry the position's index as bscan_in_volume; the output B-scan
// takes the first repeat's marker with the volume start/end flags of all of them. A volume then
// holds bscans_per_volume / R positions.
#pragma once

#include <cstdint>

#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu {

// The marker of output B-scan `position` of a group whose header is `header`.
inline shm::BscanMarker position_marker(const shm::SlotHeader& header, std::uint32_t position,
                                        std::uint32_t repeats) noexcept {
  shm::BscanMarker marker = header.bscans[position * repeats];
  for (std::uint32_t r = 1; r < repeats; ++r) {
    marker.flags |= header.bscans[position * repeats + r].flags &
                    (shm::kBscanVolumeStart | shm::kBscanVolumeEnd);
  }
  return marker;
}

}  // namespace ioct::gpu
