// The small pieces under the live loop: the worker pool and the latest-wins worker that writes
// the live files (the latency histogram is tested in tests/concurrency).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "ioct/gpu/latest_wins_worker.hpp"
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

// A task that blocks (a disk that does not answer) holds up neither the caller nor the newest
// task: submit returns at once, the tasks waiting meanwhile are replaced by the newest, and stop()
// still runs that one before it returns.
// The start hook runs once on every worker thread (not on the caller), before any iteration.
TEST(WorkerPool, EveryWorkerRunsTheStartHookFirst) {
  std::mutex mutex;
  std::set<std::thread::id> started;
  {
    WorkerPool pool(4, [&] {
      std::lock_guard lock(mutex);
      started.insert(std::this_thread::get_id());
    });
    std::atomic<int> ran_unstarted{0};
    pool.run(64, [&](std::uint32_t, unsigned worker) {
      if (worker == 0) return;
      std::lock_guard lock(mutex);
      if (started.count(std::this_thread::get_id()) == 0) ran_unstarted.fetch_add(1);
    });
    EXPECT_EQ(ran_unstarted.load(), 0);
  }  // joined: every worker has started
  EXPECT_EQ(started.size(), 3u);
  EXPECT_EQ(started.count(std::this_thread::get_id()), 0u);
}

TEST(LatestWinsWorker, TheCallerNeverWaitsAndOnlyTheNewestWaitingTaskRuns) {
  LatestWinsWorker worker;
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> first_started;
  std::vector<int> ran;  // written by the worker's thread only, read after stop()
  worker.submit([&] {
    first_started.set_value();
    released.wait();
    ran.push_back(0);
  });
  first_started.get_future().wait();
  const auto begin = std::chrono::steady_clock::now();
  for (int i = 1; i <= 5; ++i) worker.submit([&ran, i] { ran.push_back(i); });
  EXPECT_LT(std::chrono::steady_clock::now() - begin, std::chrono::seconds(1))
      << "submit waited for the blocked task";
  release.set_value();
  worker.stop();
  EXPECT_EQ(ran, (std::vector<int>{0, 5}));
  const LatestWinsWorker::Counts counts = worker.counts();
  EXPECT_EQ(counts.done, 2u);
  EXPECT_EQ(counts.replaced, 4u);
  EXPECT_EQ(counts.failed, 0u);
  worker.submit([&ran] { ran.push_back(99); });  // after stop(): ignored
  worker.stop();
  EXPECT_EQ(ran.size(), 2u);
}

TEST(LatestWinsWorker, AFailingTaskIsCountedWithItsReasonAndTheNextStillRuns) {
  LatestWinsWorker worker;
  std::atomic<int> after{0};
  std::promise<void> failed;
  worker.submit([&] {
    failed.set_value();
    throw std::runtime_error("cannot write /nowhere/render.png: No such file or directory");
  });
  failed.get_future().wait();
  worker.submit([&] { after.fetch_add(1); });
  worker.stop();
  const LatestWinsWorker::Counts counts = worker.counts();
  EXPECT_EQ(counts.failed, 1u);
  EXPECT_EQ(counts.done, 1u);
  EXPECT_EQ(after.load(), 1);
  EXPECT_NE(counts.problem.find("/nowhere/render.png"), std::string::npos) << counts.problem;
}

}  // namespace
}  // namespace ioct::gpu
