// The wake-up latency's power-of-two microsecond buckets (the status's "counts", a Prometheus
// histogram in /metrics) are derived from the common LatencyHistogram: each bucket must hold
// exactly the samples a direct count puts there.
#include "wake_latency_buckets.hpp"

#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cstdint>
#include <random>

namespace ioct::rt {
namespace {

TEST(WakeLatencyBuckets, MatchADirectCountOfRandomLatencies) {
  std::mt19937_64 random(11);
  std::uniform_int_distribution<unsigned> shift(0, 34);
  LatencyHistogram h;
  std::array<std::uint64_t, kWakeBuckets> expected{};
  for (int i = 0; i < 50'000; ++i) {
    const std::uint64_t ns = random() >> (29 + shift(random));  // 0 ns .. about 34 s
    h.record(ns);
    const auto width = static_cast<std::size_t>(std::bit_width(ns / 1000));  // 0 below 1 us
    ++expected[std::min(width, kWakeBuckets - 1)];
  }
  // Every edge itself, which belongs to the bucket above it.
  for (std::size_t i = 0; i + 1 < kWakeBuckets; ++i) {
    h.record(wake_bucket_upper_ns(i));
    ++expected[i + 1];
  }
  EXPECT_EQ(wake_bucket_counts(h), expected);
  EXPECT_EQ(wake_bucket_upper_ns(0), 1000u);
  EXPECT_EQ(wake_bucket_upper_ns(kWakeBuckets - 2), std::uint64_t{1000} << 22);
  EXPECT_EQ(wake_bucket_upper_ns(kWakeBuckets - 1), std::uint64_t{1000} << 22)
      << "the overflow bucket reports its lower edge";
}

}  // namespace
}  // namespace ioct::rt
