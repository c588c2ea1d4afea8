#include "ioct/gpu/worker_pool.hpp"

#include <stdexcept>
#include <utility>

namespace ioct::gpu {

WorkerPool::WorkerPool(unsigned threads) {
  if (threads == 0) throw std::invalid_argument("WorkerPool: threads must be at least 1");
  workers_.reserve(threads - 1);
  for (unsigned w = 1; w < threads; ++w) workers_.emplace_back([this, w] { worker_loop(w); });
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
  {
    std::lock_guard lock(mutex_);
    job_ = job;
    next_index_.store(0, std::memory_order_relaxed);
    busy_workers_ = static_cast<unsigned>(workers_.size());
    first_error_ = nullptr;
    ++generation_;
  }
  job_posted_.notify_all();
  work_on(job, 0);
  std::exception_ptr error;
  {
    std::unique_lock lock(mutex_);
    job_done_.wait(lock, [this] { return busy_workers_ == 0; });
    error = std::exchange(first_error_, nullptr);
  }
  if (error) std::rethrow_exception(error);
}

void WorkerPool::work_on(const Job& job, unsigned worker) noexcept {
  for (;;) {
    const std::uint32_t index = next_index_.fetch_add(1, std::memory_order_relaxed);
    if (index >= job.count) return;
    try {
      job.call(job.context, index, worker);
    } catch (...) {
      std::lock_guard lock(mutex_);
      if (!first_error_) first_error_ = std::current_exception();
    }
  }
}

void WorkerPool::worker_loop(unsigned worker) noexcept {
  std::uint64_t seen = 0;
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mutex_);
      job_posted_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation_;
      job = job_;
    }
    work_on(job, worker);
    {
      std::lock_guard lock(mutex_);
      if (--busy_workers_ == 0) job_done_.notify_one();
    }
  }
}

}  // namespace ioct::gpu
