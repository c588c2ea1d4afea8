// LatencyHistogram with its writer and a reader on two threads (as the acquisition thread and
// the status thread use it): every snapshot is a consistent past state (nothing counts down,
// nothing appears that was not recorded) and the final figures are exact. Run under
// ThreadSanitizer too.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <thread>

#include "ioct/concurrency/latency_histogram.hpp"

namespace ioct {
namespace {

TEST(LatencyHistogramStress, SnapshotsWhileRecordingOnlyEverGrow) {
  constexpr std::uint64_t kSamples = 300'000;
  LatencyHistogram h;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    // Values cycle through 1 us .. 1.024 ms, so many buckets change.
    for (std::uint64_t i = 0; i < kSamples; ++i) h.record(1000 + (i % 1024) * 1000);
    done.store(true, std::memory_order_release);
  });
  std::uint64_t snapshots = 0;
  std::uint64_t shrank = 0;
  std::uint64_t impossible = 0;
  std::uint64_t previous_count = 0;
  std::uint64_t previous_below = 0;
  while (!done.load(std::memory_order_acquire) || snapshots == 0) {
    const LatencyHistogram s = h;
    ++snapshots;
    const std::uint64_t below = s.count_below(512'000);
    if (s.count() < previous_count || below < previous_below) ++shrank;
    if (s.count() > kSamples || (s.count() != 0 && (s.max() > 1'024'000 || s.min() < 1000))) {
      ++impossible;
    }
    previous_count = s.count();
    previous_below = below;
  }
  writer.join();
  EXPECT_EQ(shrank, 0u) << "of " << snapshots << " snapshots";
  EXPECT_EQ(impossible, 0u);
  EXPECT_EQ(h.count(), kSamples);
  EXPECT_EQ(h.min(), 1000u);
  EXPECT_EQ(h.max(), 1'024'000u);
  // Each of the 1024 values was recorded kSamples / 1024 times or once more.
  EXPECT_EQ(h.count_below(512'000),
            (kSamples / 1024) * 511 + std::min<std::uint64_t>(kSamples % 1024, 511));
}

}  // namespace
}  // namespace ioct
