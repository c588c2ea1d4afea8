// Writes what a reader needs to rebuild volumes into a slot header: sweep counter and times,
// status, and per B-scan its volume, its place in the volume and the commanded galvo positions.
#pragma once

#include <cstdint>

#include "ioct/hal/digitizer.hpp"
#include "ioct/hal/raster_scan.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "sweep_clock.hpp"

namespace ioct::rt {

// What the acquisition knows about a group besides the digitizer's report.
struct ScanContext {
  hal::DigitizerConfig geometry;
  hal::RasterScan scan;
  std::uint32_t scan_generation = 1;  // 1 for the pattern the producer starts with
  std::uint32_t extra_status = 0;     // shm::kStatus* that hold for every group (simulated, laser)
};

// The ring's status flags for a group: the digitizer's findings plus `extra_status`.
std::uint32_t ring_status_flags(const hal::GroupInfo& info, std::uint32_t extra_status) noexcept;

// Fills every field of `header` that the producer owns (the ring stamps group index, epoch,
// payload size and publish time). Markers past the group's B-scans are zeroed.
void describe_group(shm::SlotHeader& header, const hal::GroupInfo& info, const GroupTimes& times,
                    const ScanContext& context) noexcept;

}  // namespace ioct::rt
