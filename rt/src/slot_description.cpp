#include "slot_description.hpp"

namespace ioct::rt {

std::uint32_t ring_status_flags(const hal::GroupInfo& info, std::uint32_t extra_status) noexcept {
  std::uint32_t flags = extra_status;
  if ((info.status & hal::kGroupOverrun) != 0) flags |= shm::kStatusOverrun;
  if ((info.status & hal::kGroupClockFault) != 0) flags |= shm::kStatusClockFault;
  if ((info.status & hal::kGroupMissedTriggers) != 0 || info.missed_sweeps != 0) {
    flags |= shm::kStatusMissedTriggers;
  }
  return flags;
}

void describe_group(shm::SlotHeader& header, const hal::GroupInfo& info, const GroupTimes& times,
                    const ScanContext& context) noexcept {
  const hal::DigitizerConfig& geometry = context.geometry;
  const hal::RasterScan& scan = context.scan;
  header.first_sweep_counter = info.first_sweep_counter;
  header.t_first_sweep_ns = times.first_sweep_ns;
  header.t_last_sweep_ns = times.last_sweep_ns;
  header.bscan_count = geometry.bscans_per_group;
  header.active_ascan_begin = 0;
  header.active_ascan_end = geometry.ascans_per_bscan;
  header.scan_pattern_id = static_cast<std::uint32_t>(hal::ScanPatternKind::raster);
  header.scan_generation = context.scan_generation;
  header.status_flags = ring_status_flags(info, context.extra_status);
  header.missed_sweeps = info.missed_sweeps;
  header.reserved0 = 0;

  const std::uint64_t first_bscan = info.first_sweep_counter / geometry.sweeps_per_bscan();
  const std::uint32_t last_ascan = geometry.ascans_per_bscan - 1;
  for (std::uint32_t b = 0; b < header.bscans.size(); ++b) {
    shm::BscanMarker& marker = header.bscans[b];
    if (b >= geometry.bscans_per_group) {
      marker = shm::BscanMarker{};
      continue;
    }
    const std::uint64_t bscan = first_bscan + b;
    const std::uint32_t line = scan.bscan_in_volume(bscan);
    marker.volume_index = scan.volume_index(bscan);
    marker.bscan_in_volume = line;
    marker.flags = (line == 0 ? shm::kBscanVolumeStart : 0u) |
                   (line + 1 == scan.bscans_per_volume ? shm::kBscanVolumeEnd : 0u);
    const hal::BeamPosition start = scan.position(line, 0);
    const hal::BeamPosition end = scan.position(line, last_ascan);
    marker.galvo_start[0] = start.x;
    marker.galvo_start[1] = start.y;
    marker.galvo_end[0] = end.x;
    marker.galvo_end[1] = end.y;
  }
}

}  // namespace ioct::rt
