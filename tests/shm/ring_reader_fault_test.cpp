// Readers that die in mid-read or stop reading for seconds must not change how the writer
// publishes: it never waits for a reader, so its cadence and publish durations stay what they
// were before. A dead reader's status object is reported dead and reaped; a stopped one is not.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/reader_status.hpp"
#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "paced_writer.hpp"
#include "peer_line.hpp"
#include "stalling_reader.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using namespace std::chrono_literals;
using test_support::ChildProcess;
using test_support::ScopedShmName;

constexpr auto kPeriod = 250us;
constexpr std::uint64_t kPeriodNs = 250'000;

// Bounds chosen for a loaded two-core CI machine and sanitizer builds. A publish takes about a
// microsecond; a writer that waited for a dead or stopped reader would take seconds or forever,
// far beyond any of these.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr std::uint64_t kMaxPublishNs = 250'000'000;
constexpr std::uint64_t kMaxP99PublishNs = 10'000'000;
#else
constexpr std::uint64_t kMaxPublishNs = 50'000'000;
constexpr std::uint64_t kMaxP99PublishNs = 2'000'000;
#endif
constexpr std::uint64_t kMaxLatenessNs = 1'000'000'000;

void sleep_until_ns(std::uint64_t monotonic) {
  // steady_clock is CLOCK_MONOTONIC on Linux, the clock of ioct::monotonic_ns().
  std::this_thread::sleep_until(
      std::chrono::steady_clock::time_point(std::chrono::nanoseconds(monotonic)));
}

double us(std::uint64_t ns) {
  return static_cast<double>(ns) / 1e3;
}

void print(const char* phase, const PublishWindow& w) {
  std::printf(
      "[ timing   ] %-26s groups %5zu of %7.0f due  interval p50 %6.1f us  publish p50 "
      "%6.2f us p99 %7.2f us max %8.2f us  max lateness %8.1f us\n",
      phase, w.groups, w.expected_groups, us(w.p50_interval_ns), us(w.p50_duration_ns),
      us(w.p99_duration_ns), us(w.max_duration_ns), us(w.max_lateness_ns));
}

// The writer kept publishing every group at its pace, each as fast as before. (The interval
// between groups is printed, not bounded: a writer the machine delayed catches up in a burst of
// short intervals, by design.)
void expect_writer_undisturbed(const PublishWindow& before, const PublishWindow& w,
                               const char* phase) {
  SCOPED_TRACE(phase);
  EXPECT_GE(static_cast<double>(w.groups), 0.75 * w.expected_groups) << "the writer fell behind";
  EXPECT_LE(w.p50_duration_ns, 3 * before.p50_duration_ns + 2'000)
      << "publish p50 before: " << before.p50_duration_ns << " ns";
  EXPECT_LE(w.p99_duration_ns, kMaxP99PublishNs);
  EXPECT_LE(w.max_duration_ns, kMaxPublishNs);
  EXPECT_LE(w.max_lateness_ns, kMaxLatenessNs);
}

const shm::ReaderReport* find_report(const std::vector<shm::ReaderReport>& reports,
                                     const std::string& object_name) {
  const auto it = std::find_if(reports.begin(), reports.end(), [&](const shm::ReaderReport& r) {
    return r.object_name == object_name;
  });
  return it == reports.end() ? nullptr : &*it;
}

TEST(RingReaderFaults, ReaderKilledInMidReadLeavesWriterUndisturbedAndIsReaped) {
  const ScopedShmName name("killed-reader");
  shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  shm::ReaderOptions bystander_options;
  bystander_options.label = "bystander";
  shm::RingReader bystander = shm::RingReader::attach(name.str(), bystander_options);

  PacedWriter paced(writer, kPeriod, 40'000);  // at most 10 s; stopped when done
  const std::uint64_t t0 = paced.start_ns();
  sleep_until_ns(t0 + 200'000'000);  // warm-up
  const std::uint64_t before_from = ioct::monotonic_ns();
  sleep_until_ns(before_from + 600'000'000);
  const std::uint64_t before_to = ioct::monotonic_ns();

  ChildProcess stuck = ChildProcess::spawn(test_support::sibling_executable("ring_stress_peer"),
                                           {"stuck-reader", "--ring", name.str()});
  const auto line = stuck.read_line(30s);
  ASSERT_TRUE(line) << "the stuck reader took no ticket";
  const auto holding = parse_peer_line(*line);
  ASSERT_TRUE(holding && holding->kind == "holding") << *line;
  const std::string stuck_status = holding->field("status");
  const std::uint64_t during_from = ioct::monotonic_ns();
  {
    const auto reports = writer.readers();
    const shm::ReaderReport* report = find_report(reports, stuck_status);
    ASSERT_NE(report, nullptr);
    EXPECT_TRUE(report->alive);
    EXPECT_EQ(report->pid, static_cast<std::uint64_t>(stuck.pid()));
  }
  sleep_until_ns(during_from + 600'000'000);
  const std::uint64_t during_to = ioct::monotonic_ns();

  const int status = stuck.kill_and_wait();  // SIGKILL between begin_read and end_read
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
      << test_support::describe_wait_status(status);
  const std::uint64_t after_from = ioct::monotonic_ns();
  sleep_until_ns(after_from + 600'000'000);
  const std::uint64_t after_to = ioct::monotonic_ns();
  const std::vector<PublishTiming>& timings = paced.stop();

  const PublishWindow before = publish_window(timings, kPeriodNs, before_from, before_to);
  const PublishWindow during = publish_window(timings, kPeriodNs, during_from, during_to);
  const PublishWindow after = publish_window(timings, kPeriodNs, after_from, after_to);
  print("before", before);
  print("reader stuck in mid-read", during);
  print("after SIGKILL", after);
  expect_writer_undisturbed(before, before, "before");
  expect_writer_undisturbed(before, during, "while the reader holds a ticket");
  expect_writer_undisturbed(before, after, "after the reader was killed");

  // The dead reader is reported dead, and only it is reaped.
  const auto reports = shm::scan_reader_status(name.str());
  ASSERT_EQ(reports.size(), 2u);
  const shm::ReaderReport* dead = find_report(reports, stuck_status);
  const shm::ReaderReport* alive = find_report(reports, *bystander.status_object_name());
  ASSERT_NE(dead, nullptr);
  ASSERT_NE(alive, nullptr);
  EXPECT_FALSE(dead->alive);
  EXPECT_TRUE(alive->alive);
  EXPECT_EQ(writer.reap_dead_readers(), 1u);
  EXPECT_FALSE(shm::ShmObject::exists(stuck_status));
  const auto left = shm::scan_reader_status(name.str());
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0].object_name, *bystander.status_object_name());
  EXPECT_EQ(writer.reap_dead_readers(), 0u);

  // The bystander still accounts for every group.
  const StallingReadResult r = read_stalling(bystander, writer.published(), ReadApi::copy, {},
                                             std::chrono::steady_clock::now() + 30s);
  ASSERT_TRUE(r.caught_up);
  EXPECT_EQ(r.verifier.failures(), 0u) << r.verifier.first_failure();
  EXPECT_EQ(r.counters.consumed + r.counters.dropped(), writer.published());
}

TEST(RingReaderFaults, ReaderStoppedForSecondsLeavesWriterUndisturbedAndCatchesUp) {
  const ScopedShmName name("stopped-reader");
  shm::RingWriter writer = shm::RingWriter::create(small_test_config(name.str()));
  constexpr std::uint64_t kGroups = 14'000;  // 3.5 s
  ChildProcess reader =
      ChildProcess::spawn(test_support::sibling_executable("ring_stress_peer"),
                          {"reader", "--ring", name.str(), "--groups", std::to_string(kGroups),
                           "--timeout-s", "60", "--label", "stopped", "--idle-sleep-us", "50"});
  const auto line = reader.read_line(30s);
  ASSERT_TRUE(line) << "the reader did not attach";
  const auto ready = parse_peer_line(*line);
  ASSERT_TRUE(ready && ready->kind == "ready") << *line;
  const std::string reader_status = ready->field("status");

  PacedWriter paced(writer, kPeriod, kGroups);
  const std::uint64_t t0 = paced.start_ns();
  sleep_until_ns(t0 + 200'000'000);
  const std::uint64_t before_from = ioct::monotonic_ns();
  sleep_until_ns(before_from + 600'000'000);
  const std::uint64_t before_to = ioct::monotonic_ns();

  reader.send_signal(SIGSTOP);  // stops reading, heartbeat and all, for two seconds
  const std::uint64_t during_from = ioct::monotonic_ns();
  sleep_until_ns(during_from + 1'500'000'000);
  {
    // Stopped is not dead: reported alive with a stale heartbeat, and not reaped.
    const auto reports = writer.readers();
    const shm::ReaderReport* report = find_report(reports, reader_status);
    ASSERT_NE(report, nullptr);
    EXPECT_TRUE(report->alive);
    EXPECT_GE(report->heartbeat_age_ns, 1'000'000'000u);
    EXPECT_EQ(writer.reap_dead_readers(), 0u);
  }
  sleep_until_ns(during_from + 2'000'000'000);
  const std::uint64_t during_to = ioct::monotonic_ns();
  reader.send_signal(SIGCONT);
  const std::uint64_t after_from = ioct::monotonic_ns();
  sleep_until_ns(after_from + 600'000'000);
  const std::uint64_t after_to = ioct::monotonic_ns();
  const std::vector<PublishTiming>& timings = paced.finish();
  ASSERT_EQ(timings.size(), kGroups);

  const PublishWindow before = publish_window(timings, kPeriodNs, before_from, before_to);
  const PublishWindow during = publish_window(timings, kPeriodNs, during_from, during_to);
  const PublishWindow after = publish_window(timings, kPeriodNs, after_from, after_to);
  print("before", before);
  print("reader stopped (SIGSTOP)", during);
  print("after SIGCONT", after);
  expect_writer_undisturbed(before, before, "before");
  expect_writer_undisturbed(before, during, "while the reader is stopped");
  expect_writer_undisturbed(before, after, "after the reader resumed");

  // The reader resumes, resyncs past what it missed, and accounts for every group.
  const auto result_line = reader.read_line(60s);
  ASSERT_TRUE(result_line) << "no result from the reader";
  const auto result = parse_peer_line(*result_line);
  ASSERT_TRUE(result && result->kind == "result") << *result_line;
  std::printf("[ stats    ] %s\n", result_line->c_str());
  EXPECT_EQ(result->number("caught_up"), 1u);
  EXPECT_EQ(result->number("failures"), 0u) << result->text;
  EXPECT_EQ(result->number("start"), 0u);
  EXPECT_EQ(result->number("consumed") + result->number("dropped_lapped") +
                result->number("dropped_behind"),
            kGroups);
  // Two seconds are thousands of groups against 8 slots: it had to skip a ring's worth.
  EXPECT_GT(result->number("dropped_behind"), 1000u);
  EXPECT_GE(result->number("resyncs"), 1u);
  EXPECT_GT(result->number("consumed"), 1000u) << "it read while it was not stopped";
  const auto exit_status = reader.wait_for(10s);
  ASSERT_TRUE(exit_status);
  EXPECT_TRUE(WIFEXITED(*exit_status) && WEXITSTATUS(*exit_status) == 0);
}

}  // namespace
}  // namespace ioct::ring_test
