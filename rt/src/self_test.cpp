#include "self_test.hpp"

#include <sys/utsname.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <thread>
#include <vector>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "wake_latency_buckets.hpp"

namespace ioct::rt {
namespace {

std::string first_line(const char* path) {
  std::ifstream in(path);
  std::string line;
  if (in) std::getline(in, line);
  return line;
}

std::string printf_string(const char* format, auto... values) {
  char text[512];
  const int length = std::snprintf(text, sizeof(text), format, values...);
  return std::string(text, static_cast<std::size_t>(std::clamp(length, 0, 511)));
}

double us(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-3;
}

}  // namespace

SelfTestResult run_self_test(const SelfTestSettings& settings) {
  SelfTestResult result;
  const auto count = static_cast<std::size_t>(std::max<long long>(
      1, std::llround(settings.seconds * 1e9 / static_cast<double>(settings.interval_ns))));
  std::vector<std::uint64_t> latencies(count, 0);  // allocated and touched before the thread runs
  if (settings.realtime.lock_memory) result.outcome.memory_lock_error = lock_process_memory();
  LatencyHistogram histogram;

  std::thread thread([&] {
    make_current_thread_realtime(settings.realtime, result.outcome);
    prefault_stack(256 * 1024);
    std::uint64_t next = ioct::monotonic_ns() + settings.interval_ns;
    for (std::size_t i = 0; i < count; ++i) {
      const timespec wake{static_cast<time_t>(next / 1'000'000'000u),
                          static_cast<long>(next % 1'000'000'000u)};
      while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr) != 0) {
      }
      const std::uint64_t now = ioct::monotonic_ns();
      const std::uint64_t late = now > next ? now - next : 0;
      latencies[i] = late;
      histogram.record(late);
      next += settings.interval_ns;
      // A wake-up so late that it missed whole periods restarts the grid (as cyclictest does).
      if (now > next) next = now + settings.interval_ns;
    }
  });
  thread.join();

  result.samples = count;
  result.histogram = histogram;
  std::sort(latencies.begin(), latencies.end());
  const auto at = [&](double q) {
    return latencies[std::min(count - 1, static_cast<std::size_t>(q * static_cast<double>(count)))];
  };
  result.min_ns = latencies.front();
  result.max_ns = latencies.back();
  result.p50_ns = at(0.5);
  result.p99_ns = at(0.99);
  result.p999_ns = at(0.999);
  result.mean_ns = result.histogram.mean_ns();
  result.over_threshold = static_cast<std::uint64_t>(
      latencies.end() -
      std::upper_bound(latencies.begin(), latencies.end(), settings.threshold_ns));
  result.passed = result.max_ns <= settings.threshold_ns;
  return result;
}

std::string format_self_test(const SelfTestSettings& settings, const SelfTestResult& r) {
  utsname name{};
  ::uname(&name);
  const std::string rt_kernel = kernel_is_preempt_rt() ? "PREEMPT_RT" : "not PREEMPT_RT";
  std::string isolated = first_line("/sys/devices/system/cpu/isolated");
  if (isolated.empty()) isolated = "none";
  std::string text;
  text += printf_string("self-test: kernel %s %s (%s), %u CPUs, isolated CPUs: %s\n", name.sysname,
                        name.release, rt_kernel.c_str(), std::thread::hardware_concurrency(),
                        isolated.c_str());
  const std::string shortfall = describe_shortfall(settings.realtime, r.outcome);
  const std::string policy = settings.realtime.fifo_priority > 0
                                 ? printf_string("SCHED_FIFO %d%s", settings.realtime.fifo_priority,
                                                 r.outcome.fifo_error == 0 ? "" : " (refused)")
                                 : std::string("SCHED_OTHER (no real-time priority asked)");
  const std::string cpu = settings.realtime.cpu >= 0
                              ? printf_string("pinned to CPU %d%s", settings.realtime.cpu,
                                              r.outcome.affinity_error == 0 ? "" : " (refused)")
                              : std::string("not pinned");
  text += printf_string("self-test: thread %s, %s, memory %s\n", policy.c_str(), cpu.c_str(),
                        !settings.realtime.lock_memory     ? "not locked (not asked)"
                        : r.outcome.memory_lock_error == 0 ? "locked"
                                                           : "not locked (refused)");
  if (!shortfall.empty()) text += "self-test: " + shortfall + "\n";
  text += printf_string(
      "self-test: %llu wake-ups every %.0f us over %.1f s: latency min %.1f us, mean %.1f us, "
      "p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us\n",
      static_cast<unsigned long long>(r.samples), us(settings.interval_ns), settings.seconds,
      us(r.min_ns), r.mean_ns * 1e-3, us(r.p50_ns), us(r.p99_ns), us(r.p999_ns), us(r.max_ns));
  text += "self-test: histogram (us, count):";
  const std::array<std::uint64_t, kWakeBuckets> counts = wake_bucket_counts(r.histogram);
  for (std::size_t i = 0; i < kWakeBuckets; ++i) {
    if (counts[i] == 0) continue;
    text += printf_string(" <%llu:%llu",
                          static_cast<unsigned long long>(wake_bucket_upper_ns(i) / 1000),
                          static_cast<unsigned long long>(counts[i]));
  }
  text += "\n";
  text += printf_string(
      "self-test: %s: worst wake-up %.1f us %s the threshold of %.1f us (%llu over)\n",
      r.passed ? "PASS" : "FAIL", us(r.max_ns), r.passed ? "within" : "beyond",
      us(settings.threshold_ns), static_cast<unsigned long long>(r.over_threshold));
  return text;
}

}  // namespace ioct::rt
