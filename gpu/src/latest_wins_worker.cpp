#include "ioct/gpu/latest_wins_worker.hpp"

#include <exception>
#include <utility>

namespace ioct::gpu {

LatestWinsWorker::LatestWinsWorker() : thread_([this] { work(); }) {}

LatestWinsWorker::~LatestWinsWorker() {
  stop();
}

void LatestWinsWorker::submit(std::function<void()> task) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    if (waiting_) ++counts_.replaced;
    waiting_ = std::move(task);
  }
  wake_.notify_one();
}

void LatestWinsWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

LatestWinsWorker::Counts LatestWinsWorker::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

void LatestWinsWorker::work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || waiting_; });
    if (!waiting_) return;  // stopping, with nothing left to run
    const std::function<void()> task = std::exchange(waiting_, nullptr);
    lock.unlock();
    std::string problem;
    bool failed = false;
    try {
      task();
    } catch (const std::exception& e) {
      failed = true;
      problem = e.what();
    } catch (...) {
      failed = true;
      problem = "an exception that is not a std::exception";
    }
    lock.lock();
    if (failed) {
      ++counts_.failed;
      counts_.problem = std::move(problem);
    } else {
      ++counts_.done;
    }
  }
}

}  // namespace ioct::gpu
