// The small pieces under the live loop: the latency histogram and the worker pool.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "ioct/gpu/latency_histogram.hpp"
#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu {
namespace {

TEST(LatencyHistogram, QuantilesAreWithinTheBucketResolution) {
  LatencyHistogram h;
  EXPECT_EQ(h.quantile(0.5), 0u);
  // 1 us .. 10 ms in 1 us steps, shuffled order does not matter for a histogram.
  for (std::uint64_t us = 1; us <= 10'000; ++us) h.record(us * 1000);
  EXPECT_EQ(h.count(), 10'000u);
  EXPECT_EQ(h.min(), 1000u);
  EXPECT_EQ(h.max(), 10'000'000u);
  EXPECT_NEAR(static_cast<double>(h.quantile(0.50)), 5.0e6, 5.0e6 * 0.016);
  EXPECT_NEAR(static_cast<double>(h.quantile(0.99)), 9.9e6, 9.9e6 * 0.016);
  EXPECT_EQ(h.quantile(1.0), 10'000'000u);
  EXPECT_EQ(h.quantile(0.0), 1000u);
}

TEST(LatencyHistogram, SmallValuesAreExactAndMergeAddsUp) {
  LatencyHistogram a;
  LatencyHistogram b;
  for (std::uint64_t v = 0; v < 10; ++v) a.record(v);
  for (std::uint64_t v = 10; v < 20; ++v) b.record(v);
  a.merge(b);
  EXPECT_EQ(a.count(), 20u);
  EXPECT_EQ(a.quantile(0.5), 9u);
  EXPECT_EQ(a.max(), 19u);
  a.record(~std::uint64_t{0});
  EXPECT_EQ(a.max(), ~std::uint64_t{0});
  a.reset();
  EXPECT_EQ(a.count(), 0u);
}

TEST(WorkerPool, RunsEveryIndexOnceOnEveryPoolSize) {
  for (unsigned threads : {1u, 2u, 3u}) {
    WorkerPool pool(threads);
    EXPECT_EQ(pool.threads(), threads);
    for (int round = 0; round < 50; ++round) {
      const std::uint32_t count = static_cast<std::uint32_t>(round % 17);
      std::vector<std::atomic<int>> calls(count);
      std::atomic<bool> bad_worker{false};
      pool.run(count, [&](std::uint32_t i, unsigned worker) {
        calls[i].fetch_add(1);
        if (worker >= threads) bad_worker = true;
      });
      for (std::uint32_t i = 0; i < count; ++i) EXPECT_EQ(calls[i].load(), 1) << i;
      EXPECT_FALSE(bad_worker);
    }
  }
}

TEST(WorkerPool, RethrowsATaskErrorAfterTheOthersFinish) {
  WorkerPool pool(2);
  std::atomic<int> done{0};
  EXPECT_THROW(pool.run(8,
                        [&](std::uint32_t i, unsigned) {
                          if (i == 3) throw std::runtime_error("task 3");
                          ++done;
                        }),
               std::runtime_error);
  EXPECT_EQ(done.load(), 7);
  // The pool is still usable.
  std::atomic<int> again{0};
  pool.run(4, [&](std::uint32_t, unsigned) { ++again; });
  EXPECT_EQ(again.load(), 4);
  EXPECT_THROW(WorkerPool(0), std::invalid_argument);
}

}  // namespace
}  // namespace ioct::gpu
