// What ioct-rt writes into a slot header: times from the sweep counter, status flags, and B-scan
// markers from the scan that holds for the group: volume, line, volume start/end, reversed lines,
// active range, pattern and generation, and the commanded galvo positions.
#include "slot_description.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "ioct/scan/scan_builder.hpp"

namespace ioct::rt {
namespace {

// 8 A-scans + 2 flyback sweeps per line, 4 lines per group, 6 lines per volume: groups straddle
// volume boundaries.
hal::DigitizerConfig geometry() {
  hal::DigitizerConfig g;
  g.samples_per_ascan = 32;
  g.ascans_per_bscan = 8;
  g.flyback_sweeps = 2;
  g.bscans_per_group = 4;
  return g;
}

scan::ScanPattern pattern(scan::ScanKind kind, std::uint32_t inactive = 0) {
  scan::ScanSpec s;
  s.kind = kind;
  s.extent_x = s.extent_y = 1.0;
  s.inactive_ascans = inactive;
  if (kind == scan::ScanKind::bidirectional) s.extent_x = 0.5;
  return scan::build_scan_pattern(s, {8, 2, 6, 100'000.0}, {1e9, 1e15});
}

TEST(GroupTimes, FollowTheSweepCounter) {
  const SweepClock clock(1'000, 10'000.0);  // sweeps every 10 us from t = 1 us
  const GroupTimes times = group_times(clock, geometry(), 40);
  EXPECT_EQ(times.first_sweep_ns, 1'000u + 40 * 10'000u);
  // Last recorded sweep: 3 lines of 10 sweeps on, then the 8th A-scan of the 4th line.
  EXPECT_EQ(times.last_sweep_ns, 1'000u + (40 + 30 + 7) * 10'000u);
  EXPECT_EQ(times.complete_ns, 1'000u + (40 + 30 + 8) * 10'000u);
}

TEST(SlotDescription, MarkersPlaceEachLineInItsVolume) {
  const scan::ScanPattern raster = pattern(scan::ScanKind::raster);
  const ScheduledScan scan{0, 0, 3, &raster};
  shm::SlotHeader header;
  std::memset(&header, 0xFF, sizeof(header));  // whatever the slot held before
  hal::GroupInfo info;
  info.first_sweep_counter = 40;  // group 1: lines 4..7 of the run
  const GroupTimes times{100, 200, 210};
  describe_group(header, info, times, geometry(), scan,
                 shm::kStatusSimulated | shm::kStatusLaserOn);

  EXPECT_EQ(header.first_sweep_counter, 40u);
  EXPECT_EQ(header.t_first_sweep_ns, 100u);
  EXPECT_EQ(header.t_last_sweep_ns, 200u);
  EXPECT_EQ(header.bscan_count, 4u);
  EXPECT_EQ(header.active_ascan_begin, 0u);
  EXPECT_EQ(header.active_ascan_end, 8u);
  EXPECT_EQ(header.scan_pattern_id, static_cast<std::uint32_t>(scan::ScanKind::raster));
  EXPECT_EQ(header.scan_generation, 3u);
  EXPECT_EQ(header.status_flags, shm::kStatusSimulated | shm::kStatusLaserOn);
  EXPECT_EQ(header.missed_sweeps, 0u);

  const std::uint64_t volume[] = {0, 0, 1, 1};
  const std::uint32_t line[] = {4, 5, 0, 1};
  const std::uint32_t flags[] = {0, shm::kBscanVolumeEnd, shm::kBscanVolumeStart, 0};
  for (int b = 0; b < 4; ++b) {
    SCOPED_TRACE(b);
    const shm::BscanMarker& marker = header.bscans[b];
    EXPECT_EQ(marker.volume_index, volume[b]);
    EXPECT_EQ(marker.bscan_in_volume, line[b]);
    EXPECT_EQ(marker.flags, flags[b]);
    // Left to right across the field; the slow axis steps from -1 to +1 over 6 lines.
    EXPECT_FLOAT_EQ(marker.galvo_start[0], -1.0f);
    EXPECT_FLOAT_EQ(marker.galvo_end[0], 1.0f);
    const float y = -1.0f + 2.0f * static_cast<float>(line[b]) / 5.0f;
    EXPECT_FLOAT_EQ(marker.galvo_start[1], y);
    EXPECT_FLOAT_EQ(marker.galvo_end[1], y);
  }
  for (std::size_t b = 4; b < header.bscans.size(); ++b) {
    EXPECT_EQ(header.bscans[b].volume_index, 0u) << b;
    EXPECT_EQ(header.bscans[b].flags, 0u) << b;
  }
}

TEST(SlotDescription, AScheduledPatternCountsItsVolumesFromItsStart) {
  const scan::ScanPattern bidi = pattern(scan::ScanKind::bidirectional, 1);
  // Scheduled from sweep 120 (line 12 of the run), continuing the volume count at 9.
  const ScheduledScan scan{120, 9, 5, &bidi};
  shm::SlotHeader header{};
  hal::GroupInfo info;
  info.first_sweep_counter = 160;  // lines 16..19: lines 4, 5 of volume 9, 0, 1 of volume 10
  describe_group(header, info, {}, geometry(), scan, 0);
  EXPECT_EQ(header.scan_pattern_id, static_cast<std::uint32_t>(scan::ScanKind::bidirectional));
  EXPECT_EQ(header.scan_generation, 5u);
  EXPECT_EQ(header.active_ascan_begin, 1u);
  EXPECT_EQ(header.active_ascan_end, 7u);
  const std::uint64_t volume[] = {9, 9, 10, 10};
  const std::uint32_t line[] = {4, 5, 0, 1};
  const std::uint32_t flags[] = {0, shm::kBscanVolumeEnd | shm::kBscanReversed,
                                 shm::kBscanVolumeStart, shm::kBscanReversed};
  for (int b = 0; b < 4; ++b) {
    SCOPED_TRACE(b);
    EXPECT_EQ(header.bscans[b].volume_index, volume[b]);
    EXPECT_EQ(header.bscans[b].bscan_in_volume, line[b]);
    EXPECT_EQ(header.bscans[b].flags, flags[b]);
    const scan::BscanPlan& plan = bidi.bscans[line[b]];
    EXPECT_EQ(header.bscans[b].galvo_start[0], plan.start.x);
    EXPECT_EQ(header.bscans[b].galvo_end[0], plan.end.x);
  }
  EXPECT_GT(header.bscans[1].galvo_start[0], header.bscans[1].galvo_end[0]) << "right to left";
}

TEST(SlotDescription, DigitizerFindingsBecomeRingStatusFlags) {
  hal::GroupInfo info;
  EXPECT_EQ(ring_status_flags(info, shm::kStatusSimulated), shm::kStatusSimulated);
  info.status = hal::kGroupOverrun;
  EXPECT_EQ(ring_status_flags(info, 0), shm::kStatusOverrun);
  info.status = hal::kGroupClockFault;
  EXPECT_EQ(ring_status_flags(info, 0), shm::kStatusClockFault);
  info.status = hal::kGroupMissedTriggers;
  EXPECT_EQ(ring_status_flags(info, 0), shm::kStatusMissedTriggers);
  info.status = 0;
  info.missed_sweeps = 5;
  EXPECT_EQ(ring_status_flags(info, shm::kStatusLaserOn),
            shm::kStatusMissedTriggers | shm::kStatusLaserOn);
}

}  // namespace
}  // namespace ioct::rt
