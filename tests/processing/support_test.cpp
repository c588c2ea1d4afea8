// The small pieces under the live loop: the worker pool (the latency histogram is tested in
// tests/concurrency).
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu {
namespace {

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

// Jobs back to back, each with its own task: a worker that wakes late for one job must never
// run an index of it after run() returned, nor take an index of the next job with the old task.
TEST(WorkerPool, NoIterationRunsOutsideItsOwnRun) {
  WorkerPool pool(3);
  std::atomic<int> outside{0};
  for (int job = 0; job < 3000; ++job) {
    const std::uint32_t count = 2 + static_cast<std::uint32_t>(job % 5);
    std::vector<std::atomic<int>> calls(count);
    std::atomic<bool> open{true};
    pool.run(count, [&](std::uint32_t i, unsigned) {
      if (!open.load()) ++outside;
      calls[i].fetch_add(1);
    });
    open = false;
    for (std::uint32_t i = 0; i < count; ++i) ASSERT_EQ(calls[i].load(), 1) << job << " " << i;
  }
  EXPECT_EQ(outside.load(), 0);
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
