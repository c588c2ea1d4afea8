#include "ioct/gpu/processing/group_check.hpp"

#include <stdexcept>

namespace ioct::gpu {

std::optional<std::string> find_group_problem(const shm::SlotHeader& header,
                                              const shm::RingGeometry& geometry,
                                              std::size_t payload_bytes,
                                              std::uint32_t repeats_per_position) {
  const auto text = [](auto value) { return std::to_string(value); };
  if (payload_bytes < geometry.group_payload_bytes()) {
    return "payload of " + text(payload_bytes) + " bytes, the geometry needs " +
           text(geometry.group_payload_bytes());
  }
  if (header.bscan_count < 1 || header.bscan_count > geometry.bscans_per_group) {
    return "bscan_count = " + text(header.bscan_count) + " is out of range [1, " +
           text(geometry.bscans_per_group) + "]";
  }
  if (repeats_per_position > 1 && header.bscan_count % repeats_per_position != 0) {
    return "bscan_count = " + text(header.bscan_count) + " is not a multiple of " +
           text(repeats_per_position) + " repeats per position";
  }
  if (header.active_ascan_begin >= header.active_ascan_end ||
      header.active_ascan_end > geometry.ascans_per_bscan) {
    return "active A-scans [" + text(header.active_ascan_begin) + ", " +
           text(header.active_ascan_end) + ") are not a non-empty range within [0, " +
           text(geometry.ascans_per_bscan) + ")";
  }
  for (std::uint32_t b = 0; b < header.bscan_count; ++b) {
    const shm::BscanMarker& marker = header.bscans[b];
    if (marker.bscan_in_volume >= geometry.bscans_per_volume) {
      return "bscans[" + text(b) + "].bscan_in_volume = " + text(marker.bscan_in_volume) +
             " is out of range [0, " + text(geometry.bscans_per_volume) + ")";
    }
  }
  return std::nullopt;
}

void require_processable(const shm::RingGeometry& geometry) {
  geometry.validate();
  if (geometry.bytes_per_sample != 2) {
    throw std::invalid_argument(
        "ring geometry: bytes_per_sample = " + std::to_string(geometry.bytes_per_sample) +
        ", the processing chain reads 16-bit samples");
  }
  if (geometry.samples_per_ascan < 8 || geometry.samples_per_ascan % 2 != 0) {
    throw std::invalid_argument(
        "ring geometry: samples_per_ascan = " + std::to_string(geometry.samples_per_ascan) +
        " must be even and at least 8");
  }
  const std::uint64_t volume_bytes =
      std::uint64_t{geometry.bscans_per_volume} * geometry.ascans_per_bscan * depth_of(geometry);
  if (volume_bytes > (std::uint64_t{1} << 32)) {
    throw std::invalid_argument(
        "ring geometry: a volume of " + std::to_string(geometry.bscans_per_volume) + " x " +
        std::to_string(geometry.ascans_per_bscan) + " x " + std::to_string(depth_of(geometry)) +
        " pixels is larger than 4 GiB");
  }
}

}  // namespace ioct::gpu
