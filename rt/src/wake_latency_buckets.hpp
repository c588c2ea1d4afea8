// The wake-up latency as ioct-rt reports it: bucket i holds [2^(i-1), 2^i) us (bucket 0 below
// 1 us), the last bucket everything from 2^22 us (4.2 s) on. The status's "counts" (a Prometheus
// histogram in ioct-view's /metrics) and the self-test's printout use these edges. They are
// sums of the LatencyHistogram's buckets, exact because 2^i us are edges of those.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>

#include "ioct/concurrency/latency_histogram.hpp"

namespace ioct::rt {

inline constexpr std::size_t kWakeBuckets = 24;

// Upper edge of bucket i in ns (the overflow bucket reports its lower edge).
constexpr std::uint64_t wake_bucket_upper_ns(std::size_t i) noexcept {
  return (std::uint64_t{1000} << std::min(i, kWakeBuckets - 2));
}

inline std::array<std::uint64_t, kWakeBuckets> wake_bucket_counts(
    const LatencyHistogram& h) noexcept {
  static_assert(LatencyHistogram::is_bucket_edge(wake_bucket_upper_ns(kWakeBuckets - 2)));
  std::array<std::uint64_t, kWakeBuckets> counts{};
  for (std::size_t b = 0; b < LatencyHistogram::kBuckets; ++b) {
    const std::uint64_t n = h.bucket_count(b);
    if (n == 0) continue;
    const auto width =
        static_cast<std::size_t>(std::bit_width(LatencyHistogram::bucket_low(b) / 1000));
    counts[std::min(width, kWakeBuckets - 1)] += n;
  }
  return counts;
}

}  // namespace ioct::rt
