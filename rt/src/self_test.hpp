// `ioct-rt --self-test`: how late a real-time thread wakes on this machine, measured like
// cyclictest: a thread set up exactly as the acquisition thread (SCHED_FIFO, pinned, memory
// locked, stack prefaulted) sleeps to absolute CLOCK_MONOTONIC deadlines one interval apart and
// records how late each wake-up was. The worst latency is judged against a threshold.
#pragma once

#include <cstdint>
#include <string>

#include "ioct/concurrency/latency_histogram.hpp"
#include "realtime_setup.hpp"

namespace ioct::rt {

struct SelfTestSettings {
  double seconds = 10.0;
  std::uint64_t interval_ns = 1'000'000;
  std::uint64_t threshold_ns = 100'000;
  RealtimeRequest realtime;
};

struct SelfTestResult {
  RealtimeOutcome outcome;
  std::uint64_t samples = 0;
  std::uint64_t min_ns = 0;
  double mean_ns = 0.0;
  std::uint64_t p50_ns = 0;
  std::uint64_t p99_ns = 0;
  std::uint64_t p999_ns = 0;
  std::uint64_t max_ns = 0;
  std::uint64_t over_threshold = 0;  // wake-ups later than the threshold
  LatencyHistogram histogram;
  bool passed = false;  // max_ns <= threshold
};

SelfTestResult run_self_test(const SelfTestSettings& settings);

// The report: the machine (kernel, PREEMPT_RT or not, isolated CPUs), what real-time setup was
// granted, the latency figures and the verdict, one line each.
std::string format_self_test(const SelfTestSettings& settings, const SelfTestResult& result);

}  // namespace ioct::rt
