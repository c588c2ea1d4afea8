// Writes what a reader needs to rebuild volumes into a slot header: sweep counter and times,
// status, the pattern and its generation, the active A-scans, and per B-scan its volume, its
// place in the volume, whether it runs backwards and the commanded galvo positions.
#pragma once

#include <cstdint>

#include "ioct/hal/digitizer.hpp"
#include "ioct/shm/ring_layout.hpp"
#include "scan_schedule.hpp"
#include "sweep_clock.hpp"

namespace ioct::rt {

// The ring's status flags for a group: the digitizer's findings plus `extra_status`.
std::uint32_t ring_status_flags(const hal::GroupInfo& info, std::uint32_t extra_status) noexcept;

// Fills every field of `header` that the producer owns (the ring stamps group index, epoch,
// payload size and publish time). `scan` is the schedule entry that holds for the group (the
// group lies within it: patterns change only where a volume and a group start together). Markers
// past the group's B-scans are zeroed.
void describe_group(shm::SlotHeader& header, const hal::GroupInfo& info, const GroupTimes& times,
                    const hal::DigitizerConfig& geometry, const ScheduledScan& scan,
                    std::uint32_t extra_status) noexcept;

}  // namespace ioct::rt
