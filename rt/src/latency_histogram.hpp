// A histogram of latencies in power-of-two microsecond buckets, filled by one thread and read by
// another without locks: bucket 0 holds [0, 1) us, bucket i holds [2^(i-1), 2^i) us, the last
// bucket everything from 2^(kBuckets-2) us on.
#pragma once

#include <array>
#include <atomic>
#include <bit>
#include <cstdint>

namespace ioct::rt {

inline constexpr std::size_t kLatencyBuckets = 24;  // up to 4.2 s, then the overflow bucket

struct LatencySnapshot {
  std::array<std::uint64_t, kLatencyBuckets> counts{};
  std::uint64_t samples = 0;
  std::uint64_t total_ns = 0;
  std::uint64_t max_ns = 0;

  // Upper edge of bucket i in ns (the overflow bucket reports its lower edge).
  static std::uint64_t bucket_upper_ns(std::size_t i) noexcept {
    if (i + 1 >= kLatencyBuckets) return (std::uint64_t{1} << (kLatencyBuckets - 2)) * 1000;
    return (std::uint64_t{1} << i) * 1000;
  }
  // The bucket edge at or below which `fraction` of the samples lie (an upper bound of the
  // quantile, exact to a factor of two); 0 with no samples.
  std::uint64_t quantile_upper_ns(double fraction) const noexcept {
    if (samples == 0) return 0;
    const double wanted = fraction * static_cast<double>(samples);
    std::uint64_t seen = 0;
    for (std::size_t i = 0; i < kLatencyBuckets; ++i) {
      seen += counts[i];
      if (static_cast<double>(seen) >= wanted) return std::min(bucket_upper_ns(i), max_ns);
    }
    return max_ns;
  }
  double mean_ns() const noexcept {
    return samples == 0 ? 0.0 : static_cast<double>(total_ns) / static_cast<double>(samples);
  }
};

class LatencyHistogram {
 public:
  static std::size_t bucket_of(std::uint64_t ns) noexcept {
    const std::uint64_t us = ns / 1000;
    const std::size_t width = static_cast<std::size_t>(std::bit_width(us));  // 0 for 0 us
    return width < kLatencyBuckets ? width : kLatencyBuckets - 1;
  }

  // Writer thread only.
  void record(std::uint64_t ns) noexcept {
    bump(counts_[bucket_of(ns)], 1);
    bump(samples_, 1);
    bump(total_ns_, ns);
    if (ns > max_ns_.load(std::memory_order_relaxed)) max_ns_.store(ns, std::memory_order_relaxed);
  }

  // Any thread.
  LatencySnapshot snapshot() const noexcept {
    LatencySnapshot s;
    for (std::size_t i = 0; i < kLatencyBuckets; ++i) {
      s.counts[i] = counts_[i].load(std::memory_order_relaxed);
    }
    s.samples = samples_.load(std::memory_order_relaxed);
    s.total_ns = total_ns_.load(std::memory_order_relaxed);
    s.max_ns = max_ns_.load(std::memory_order_relaxed);
    return s;
  }

 private:
  static void bump(std::atomic<std::uint64_t>& word, std::uint64_t by) noexcept {
    word.store(word.load(std::memory_order_relaxed) + by, std::memory_order_relaxed);
  }
  std::array<std::atomic<std::uint64_t>, kLatencyBuckets> counts_{};
  std::atomic<std::uint64_t> samples_{0};
  std::atomic<std::uint64_t> total_ns_{0};
  std::atomic<std::uint64_t> max_ns_{0};
};

}  // namespace ioct::rt
