// What one slot of the ring carries: a group of raw B-scans, each a run of k-clock spectra.
#pragma once

#include <cstdint>

namespace ioct::shm {

// Most B-scans one group (one slot) may hold; bounds the per-B-scan markers in the slot header.
inline constexpr std::uint32_t kMaxBscansPerGroup = 64;

struct RingGeometry {
  std::uint32_t samples_per_ascan = 1376;  // k-clock samples of one sweep
  std::uint32_t ascans_per_bscan = 512;    // A-scans recorded per B-scan (the payload's)
  std::uint32_t bscans_per_group = 16;     // B-scans per slot
  std::uint32_t bscans_per_volume = 128;   // B-scans per volume, for assembly on the GPU side
  std::uint32_t bytes_per_sample = 2;      // 12-bit samples in 16-bit words

  // Bytes of one group's spectra. Throws RingError(bad_config) when the product overflows.
  std::uint64_t group_payload_bytes() const;
  std::uint64_t ascans_per_group() const {
    return std::uint64_t{ascans_per_bscan} * bscans_per_group;
  }

  // Throws RingError(bad_config) naming the first value out of range.
  void validate() const;

  friend bool operator==(const RingGeometry&, const RingGeometry&) = default;
};

}  // namespace ioct::shm
