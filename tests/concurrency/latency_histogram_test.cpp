// LatencyHistogram on one thread: its bucket edges, quantiles against a sorted reference on
// random data, counts below an edge, merge, reset and snapshots.
#include "ioct/concurrency/latency_histogram.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace ioct {
namespace {

using H = LatencyHistogram;

TEST(LatencyHistogram, BucketsTileTheValuesWithoutGapsOrOverlaps) {
  EXPECT_EQ(H::bucket_low(0), 0u);
  for (std::size_t b = 0; b < H::kOverflowBucket; ++b) {
    ASSERT_EQ(H::bucket_of(H::bucket_low(b)), b) << "bucket " << b;
    ASSERT_EQ(H::bucket_of(H::bucket_high(b) - 1), b) << "bucket " << b;
    ASSERT_EQ(H::bucket_high(b), H::bucket_low(b + 1)) << "bucket " << b;
    // Never wider than 1/128 of its smallest value (above the exact ones).
    if (b >= H::kSub) {
      ASSERT_LE((H::bucket_high(b) - H::bucket_low(b)) * 128, H::bucket_low(b));
    }
  }
}

TEST(LatencyHistogram, SmallValuesAreExactLargeOnesOverflow) {
  for (std::uint64_t v = 0; v < 128; ++v) {
    EXPECT_EQ(H::bucket_of(v), v);
    EXPECT_EQ(H::bucket_high(v), v + 1);
  }
  const std::uint64_t limit = std::uint64_t{1} << 36;
  EXPECT_EQ(H::bucket_of(limit - 1), H::kOverflowBucket - 1);
  EXPECT_EQ(H::bucket_of(limit), H::kOverflowBucket);
  EXPECT_EQ(H::bucket_of(~std::uint64_t{0}), H::kOverflowBucket);
  H h;
  h.record(~std::uint64_t{0});
  EXPECT_EQ(h.max(), ~std::uint64_t{0});
  EXPECT_EQ(h.quantile(0.5), ~std::uint64_t{0}) << "the overflow bucket reports the maximum";
}

TEST(LatencyHistogram, PowerOfTwoMicrosecondsAreBucketEdges) {
  for (unsigned k = 0; k <= 25; ++k) {
    EXPECT_TRUE(H::is_bucket_edge(std::uint64_t{1000} << k)) << "2^" << k << " us";
  }
  EXPECT_FALSE(H::is_bucket_edge(1'000'001'001));
}

std::vector<std::uint64_t> random_latencies(std::size_t n, std::uint64_t seed) {
  // Log-uniform from 10 ns to 10 s: every scale of the histogram gets samples.
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> exponent(1.0, 10.0);
  std::vector<std::uint64_t> values(n);
  for (auto& v : values) v = static_cast<std::uint64_t>(std::pow(10.0, exponent(random)));
  return values;
}

TEST(LatencyHistogram, QuantilesMatchASortedReferenceWithinTheBucketWidth) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    std::vector<std::uint64_t> values = random_latencies(100'000, seed);
    H h;
    for (std::uint64_t v : values) h.record(v);
    std::sort(values.begin(), values.end());
    EXPECT_EQ(h.count(), values.size());
    EXPECT_EQ(h.min(), values.front());
    EXPECT_EQ(h.max(), values.back());
    for (double q : {0.0, 0.001, 0.01, 0.1, 0.5, 0.9, 0.99, 0.999, 1.0}) {
      const std::size_t rank = std::max<std::size_t>(
          1, static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size()))));
      const std::uint64_t truth = values[rank - 1];
      const std::uint64_t middle = h.quantile(q);
      const std::uint64_t upper = h.quantile_upper(q);
      EXPECT_LE(std::abs(static_cast<double>(middle) - static_cast<double>(truth)),
                static_cast<double>(truth) / 128.0)
          << "q " << q << " seed " << seed;
      EXPECT_GE(upper, truth) << "q " << q << ": an upper bound";
      EXPECT_LE(static_cast<double>(upper), static_cast<double>(truth) * (1.0 + 1.0 / 128) + 1)
          << "q " << q;
    }
    EXPECT_EQ(h.quantile(0.0), values.front());
    EXPECT_EQ(h.quantile(1.0), values.back());
  }
}

TEST(LatencyHistogram, CountsBelowAnEdgeExactly) {
  std::vector<std::uint64_t> values = random_latencies(50'000, 7);
  H h;
  for (std::uint64_t v : values) h.record(v);
  for (unsigned k = 0; k <= 24; ++k) {
    const std::uint64_t edge = std::uint64_t{1000} << k;
    const auto truth = static_cast<std::uint64_t>(
        std::count_if(values.begin(), values.end(), [&](std::uint64_t v) { return v < edge; }));
    EXPECT_EQ(h.count_below(edge), truth) << "below " << edge << " ns";
  }
  EXPECT_EQ(h.count_below(~std::uint64_t{0}), h.count())
      << "every bucket ends by the largest value";
}

TEST(LatencyHistogram, MeanMergeResetAndEmpty) {
  H empty;
  EXPECT_EQ(empty.count(), 0u);
  EXPECT_EQ(empty.min(), 0u);
  EXPECT_EQ(empty.quantile(0.5), 0u);
  EXPECT_EQ(empty.quantile_upper(0.5), 0u);
  EXPECT_EQ(empty.mean_ns(), 0.0);

  H a;
  H b;
  for (std::uint64_t v = 0; v < 10; ++v) a.record(v);
  for (std::uint64_t v = 10; v < 20; ++v) b.record(v);
  a.merge(b);
  EXPECT_EQ(a.count(), 20u);
  EXPECT_EQ(a.sum_ns(), 190u);
  EXPECT_DOUBLE_EQ(a.mean_ns(), 9.5);
  EXPECT_EQ(a.quantile(0.5), 9u);
  EXPECT_EQ(a.min(), 0u);
  EXPECT_EQ(a.max(), 19u);
  a.reset();
  EXPECT_EQ(a.count(), 0u);
  EXPECT_EQ(a.max(), 0u);
  EXPECT_EQ(a.count_below(1000), 0u);
  a.record(5000);
  EXPECT_EQ(a.min(), 5000u) << "reset forgets the old minimum";
}

TEST(LatencyHistogram, ACopyIsASnapshotThatDoesNotMove) {
  H h;
  h.record(1500);
  const H snapshot = h;
  h.record(2500);
  EXPECT_EQ(snapshot.count(), 1u);
  EXPECT_EQ(snapshot.max(), 1500u);
  EXPECT_EQ(h.count(), 2u);
}

}  // namespace
}  // namespace ioct
