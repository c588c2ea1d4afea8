#include "paced_writer.hpp"

#include <time.h>

#include <algorithm>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {

PacedWriter::PacedWriter(shm::RingWriter& writer, std::chrono::nanoseconds period,
                         std::size_t group_count)
    : writer_(writer),
      period_ns_(static_cast<std::uint64_t>(period.count())),
      timings_(group_count),
      start_ns_(ioct::monotonic_ns()),
      thread_([this] { run(); }) {}

PacedWriter::~PacedWriter() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

const std::vector<PublishTiming>& PacedWriter::finish() {
  if (thread_.joinable()) thread_.join();
  timings_.resize(published());
  return timings_;
}

const std::vector<PublishTiming>& PacedWriter::stop() {
  stop_.store(true);
  return finish();
}

void PacedWriter::run() noexcept {
  for (std::size_t i = 0; i < timings_.size() && !stop_.load(std::memory_order_relaxed); ++i) {
    PublishTiming& t = timings_[i];
    t.due_ns = start_ns_ + (i + 1) * period_ns_;
    const timespec due{static_cast<time_t>(t.due_ns / 1'000'000'000),
                       static_cast<long>(t.due_ns % 1'000'000'000)};
    while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, nullptr) != 0) {
    }
    t.start_ns = ioct::monotonic_ns();
    publish_test_group(writer_);
    t.end_ns = ioct::monotonic_ns();
    published_.store(i + 1, std::memory_order_release);
  }
}

namespace {

std::uint64_t percentile(std::vector<std::uint64_t>& values, double fraction) {
  if (values.empty()) return 0;
  const auto k = static_cast<std::size_t>(fraction * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

PublishWindow publish_window(const std::vector<PublishTiming>& timings, std::uint64_t period_ns,
                             std::uint64_t from_ns, std::uint64_t to_ns) {
  PublishWindow w;
  w.expected_groups = static_cast<double>(to_ns - from_ns) / static_cast<double>(period_ns);
  std::vector<std::uint64_t> durations;
  std::vector<std::uint64_t> intervals;
  const PublishTiming* previous = nullptr;
  for (const PublishTiming& t : timings) {
    if (t.start_ns >= from_ns && t.start_ns < to_ns) {
      durations.push_back(t.end_ns - t.start_ns);
      if (previous != nullptr) intervals.push_back(t.start_ns - previous->start_ns);
      w.max_lateness_ns =
          std::max(w.max_lateness_ns, t.start_ns > t.due_ns ? t.start_ns - t.due_ns : 0);
      previous = &t;
    }
  }
  w.groups = durations.size();
  w.p50_interval_ns = percentile(intervals, 0.5);
  w.p50_duration_ns = percentile(durations, 0.5);
  w.p99_duration_ns = percentile(durations, 0.99);
  w.max_duration_ns = durations.empty() ? 0 : *std::max_element(durations.begin(), durations.end());
  return w;
}

}  // namespace ioct::ring_test
