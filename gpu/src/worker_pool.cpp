#include "ioct/gpu/worker_pool.hpp"

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/concurrency/spin_pause.hpp"

#include <stdexcept>
#include <utility>

namespace ioct::gpu {

WorkerPool::WorkerPool(unsigned threads, std::function<void()> worker_start) {
  if (threads == 0) throw std::invalid_argument("WorkerPool: threads must be at least 1");
  workers_.reserve(threads - 1);
  for (unsigned w = 1; w < threads; ++w) {
    workers_.emplace_back([this, w, worker_start] {
      if (worker_start) worker_start();
      worker_loop(w);
    });
  }
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  job_posted_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::run_erased(std::uint32_t count, void* context, Call call) {
  const Job job{context, call, count};
  if (workers_.empty() || count <= 1) {
    for (std::uint32_t i = 0; i < count; ++i) call(context, i, 0);
    return;
  }
  std::uint32_t generation = 0;
  {
    std::lock_guard lock(mutex_);
    job_ = job;
    generation = ++generation_;
    first_error_ = nullptr;
    completed_.store(0, std::memory_order_relaxed);
    next_.store(std::uint64_t{generation} << 32, std::memory_order_release);
  }
  job_posted_.notify_all();
  work_on(job, generation, 0);
  // What is left is being run by workers that took it: wait awake for a short while (a frame's
  // band or a B-scan takes well under a millisecond on the GPU host), then asleep, so a long
  // iteration on a busy CPU is not slowed by a caller spinning beside it.
  constexpr std::uint64_t kSpinNs = 200'000;
  const std::uint64_t spin_until = ioct::monotonic_ns() + kSpinNs;
  while (completed_.load(std::memory_order_acquire) < count && ioct::monotonic_ns() < spin_until) {
    spin_pause();
  }
  if (completed_.load(std::memory_order_acquire) < count) {
    std::unique_lock lock(mutex_);
    job_done_.wait(lock, [&] { return completed_.load(std::memory_order_acquire) >= count; });
  }
  std::exception_ptr error;
  {
    std::lock_guard lock(mutex_);
    error = std::exchange(first_error_, nullptr);
  }
  if (error) std::rethrow_exception(error);
}

void WorkerPool::work_on(const Job& job, std::uint32_t generation, unsigned worker) noexcept {
  std::uint64_t next = next_.load(std::memory_order_acquire);
  for (;;) {
    if (static_cast<std::uint32_t>(next >> 32) != generation) return;  // a newer job
    const auto index = static_cast<std::uint32_t>(next);
    if (index >= job.count) return;
    if (!next_.compare_exchange_weak(next, next + 1, std::memory_order_acq_rel)) continue;
    try {
      job.call(job.context, index, worker);
    } catch (...) {
      std::lock_guard lock(mutex_);
      if (!first_error_) first_error_ = std::current_exception();
    }
    if (completed_.fetch_add(1, std::memory_order_acq_rel) + 1 == job.count) {
      std::lock_guard lock(mutex_);  // the caller checks under it before it sleeps
      job_done_.notify_one();
    }
    next = next_.load(std::memory_order_acquire);
  }
}

void WorkerPool::worker_loop(unsigned worker) noexcept {
  std::uint32_t seen = 0;
  for (;;) {
    Job job;
    std::uint32_t generation = 0;
    {
      std::unique_lock lock(mutex_);
      job_posted_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation = generation_;
      job = job_;
    }
    work_on(job, generation, worker);
  }
}

}  // namespace ioct::gpu
