// What a reader checks before it trusts a group: the slot header comes from another process, so
// its counts and indices are validated against the ring's geometry before they index anything.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "ioct/shm/ring_geometry.hpp"
#include "ioct/shm/ring_layout.hpp"

namespace ioct::gpu {

// Why the group cannot be processed (naming the field and its value), or nothing when it can.
// With repeats_per_position R > 1 the group's bscan_count must be a multiple of R.
std::optional<std::string> find_group_problem(const shm::SlotHeader& header,
                                              const shm::RingGeometry& geometry,
                                              std::size_t payload_bytes,
                                              std::uint32_t repeats_per_position = 1);

// Throws std::invalid_argument, naming the value, for a geometry the processing chain cannot
// handle: samples must be 16-bit, an even count of at least 8, and a volume at most 4 GiB.
void require_processable(const shm::RingGeometry& geometry);

// Depth pixels of a processed A-scan: half the samples (the positive-frequency bins minus Nyquist).
constexpr std::uint32_t depth_of(const shm::RingGeometry& geometry) noexcept {
  return geometry.samples_per_ascan / 2;
}

}  // namespace ioct::gpu
