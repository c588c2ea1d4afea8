// A producer thread that publishes test groups at a fixed cadence and times every publish, so a
// test can show that what readers do (stall, die in mid-read) leaves the writer's pace and
// publish durations unchanged.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>

#include "ioct/shm/ring_writer.hpp"

namespace ioct::ring_test {

struct PublishTiming {
  std::uint64_t due_ns = 0;    // CLOCK_MONOTONIC deadline of this group
  std::uint64_t start_ns = 0;  // claim() begins
  std::uint64_t end_ns = 0;    // publish() has returned
};

class PacedWriter {
 public:
  // Publishes `group_count` groups, one every `period` (absolute deadlines: a late group is
  // published at once and the pace resumes), starting now.
  PacedWriter(shm::RingWriter& writer, std::chrono::nanoseconds period, std::size_t group_count);
  ~PacedWriter();
  PacedWriter(const PacedWriter&) = delete;
  PacedWriter& operator=(const PacedWriter&) = delete;

  std::uint64_t published() const noexcept { return published_.load(std::memory_order_acquire); }
  // Waits until all groups are published and returns their timings.
  const std::vector<PublishTiming>& finish();
  // Stops after the group in progress and returns the timings of those published.
  const std::vector<PublishTiming>& stop();
  std::uint64_t start_ns() const noexcept { return start_ns_; }

 private:
  void run() noexcept;

  shm::RingWriter& writer_;
  std::uint64_t period_ns_;
  std::vector<PublishTiming> timings_;  // sized up front: the loop never allocates
  std::atomic<std::uint64_t> published_{0};
  std::atomic<bool> stop_{false};
  std::uint64_t start_ns_;
  std::thread thread_;
};

// What the writer did in [from_ns, to_ns): groups that started publishing in the window.
struct PublishWindow {
  std::size_t groups = 0;
  double expected_groups = 0;  // the window's length over the period
  std::uint64_t p50_interval_ns = 0;
  std::uint64_t p50_duration_ns = 0;
  std::uint64_t p99_duration_ns = 0;
  std::uint64_t max_duration_ns = 0;
  std::uint64_t max_lateness_ns = 0;  // start after due
};

PublishWindow publish_window(const std::vector<PublishTiming>& timings, std::uint64_t period_ns,
                             std::uint64_t from_ns, std::uint64_t to_ns);

}  // namespace ioct::ring_test
