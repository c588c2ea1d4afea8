// The scan schedule on the acquisition thread: the feed follows the trajectory from the galvo
// lead on, a new pattern starts exactly where a volume and a group begin, groups are described
// with the pattern that was being scanned, and patterns come back once nothing uses them.
#include "scan_schedule.hpp"

#include <gtest/gtest.h>

#include <array>

#include "ioct/scan/scan_builder.hpp"

namespace ioct::rt {
namespace {

// 4 records + 2 flyback = 6 sweeps per B-scan, 4 B-scans per volume = 24 sweeps per volume.
const scan::ScanTiming kTiming{4, 2, 4, 1000.0};

scan::ScanPattern pattern(double extent) {
  scan::ScanSpec s;
  s.extent_x = s.extent_y = extent;
  return scan::build_scan_pattern(s, kTiming, {1e9, 1e15});
}

TEST(ScanSchedule, FeedsTheTrajectoryFromTheLeadOn) {
  const scan::ScanPattern p = pattern(0.5);
  ScanSchedule schedule;
  schedule.reset(&p, 1, 0, 12, 3);
  const auto none = []() -> const scan::ScanPattern* { return nullptr; };
  for (std::uint64_t m = 3; m < 3 + 60; ++m) {
    EXPECT_EQ(schedule.next_position(none), p.trajectory[m % 24]) << m;
  }
  EXPECT_EQ(schedule.feed_sweep(), 63u);
}

TEST(ScanSchedule, ANewPatternStartsWhereAVolumeAndAGroupBegin) {
  const scan::ScanPattern a = pattern(0.5);
  const scan::ScanPattern b = pattern(0.25);
  ScanSchedule schedule;
  // Groups of 16 sweeps, volumes of 24: they meet every 48 sweeps.
  schedule.reset(&a, 7, 100, 16, 0);
  const scan::ScanPattern* offer = nullptr;
  int asked = 0;
  const auto offered = [&]() -> const scan::ScanPattern* {
    ++asked;
    const scan::ScanPattern* p = offer;
    offer = nullptr;
    return p;
  };
  for (int i = 0; i < 10; ++i) schedule.next_position(offered);
  offer = &b;  // offered at sweep 10: taken at sweep 48
  for (std::uint64_t m = 10; m < 120; ++m) {
    const hal::GalvoSample s = schedule.next_position(offered);
    const scan::ScanPattern& expected = m < 48 ? a : b;
    ASSERT_EQ(s, expected.trajectory[m % 24]) << m;
  }
  EXPECT_EQ(asked, 2) << "asked at sweeps 48 and 96 only";
  ASSERT_EQ(schedule.entries(), 2u);
  EXPECT_EQ(schedule.at(47).pattern, &a);
  EXPECT_EQ(schedule.at(48).pattern, &b);
  EXPECT_EQ(schedule.at(48).first_volume, 102u) << "two volumes of a before it";
  EXPECT_EQ(schedule.at(48).generation, 8u);
  EXPECT_EQ(schedule.volume_at(47), 101u);
  EXPECT_EQ(schedule.volume_at(72), 103u);

  std::array<const scan::ScanPattern*, ScanSchedule::kMaxEntries> retired{};
  EXPECT_EQ(schedule.retire_before(32, retired), 0u) << "a is still being described";
  EXPECT_EQ(schedule.retire_before(48, retired), 1u);
  EXPECT_EQ(retired[0], &a);
  EXPECT_EQ(schedule.entries(), 1u);
  EXPECT_EQ(schedule.newest().pattern, &b);
}

TEST(ScanSchedule, APatternStillScheduledLaterIsNotRetired) {
  const scan::ScanPattern a = pattern(0.5);
  const scan::ScanPattern b = pattern(0.25);
  ScanSchedule schedule;
  schedule.reset(&a, 1, 0, 24, 0);
  const scan::ScanPattern* queue[] = {&b, &a};
  int next = 0;
  const auto offered = [&]() -> const scan::ScanPattern* {
    return next < 2 ? queue[next++] : nullptr;
  };
  for (int m = 0; m < 24 * 3; ++m) schedule.next_position(offered);
  ASSERT_EQ(schedule.entries(), 3u);  // a, b, a
  std::array<const scan::ScanPattern*, ScanSchedule::kMaxEntries> retired{};
  EXPECT_EQ(schedule.retire_before(24, retired), 0u) << "a comes back at sweep 48";
  EXPECT_EQ(schedule.retire_before(48, retired), 1u);
  EXPECT_EQ(retired[0], &b);
}

TEST(ScanSchedule, ALeadOnABoundaryChecksTheMailboxAtOnce) {
  const scan::ScanPattern a = pattern(0.5);
  const scan::ScanPattern b = pattern(0.25);
  ScanSchedule schedule;
  schedule.reset(&a, 1, 0, 24, 24);  // the feed starts one volume ahead
  const scan::ScanPattern* offer = &b;
  const hal::GalvoSample first = schedule.next_position([&]() -> const scan::ScanPattern* {
    const scan::ScanPattern* p = offer;
    offer = nullptr;
    return p;
  });
  EXPECT_EQ(first, b.trajectory[0]);
  EXPECT_EQ(schedule.at(24).pattern, &b);
  EXPECT_EQ(schedule.at(0).pattern, &a);
}

}  // namespace
}  // namespace ioct::rt
