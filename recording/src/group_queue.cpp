#include "ioct/ringrec/group_queue.hpp"

#include <chrono>
#include <cstring>

namespace ioct::ringrec {

GroupQueue::GroupQueue(std::size_t capacity, std::uint64_t group_bytes) : buffers_(capacity) {
  free_.reserve(capacity);
  for (std::size_t i = 0; i < capacity; ++i) {
    buffers_[i].payload.resize(group_bytes);  // value-initialised: every page touched
    free_.push_back(capacity - 1 - i);
  }
}

std::optional<std::size_t> GroupQueue::try_take_free() {
  std::lock_guard lock(mutex_);
  if (free_.empty()) return std::nullopt;
  const std::size_t index = free_.back();
  free_.pop_back();
  return index;
}

void GroupQueue::give_back_free(std::size_t index) {
  std::lock_guard lock(mutex_);
  free_.push_back(index);
}

void GroupQueue::push_filled(std::size_t index) {
  {
    std::lock_guard lock(mutex_);
    filled_.push_back(index);
  }
  filled_cv_.notify_one();
}

std::optional<std::size_t> GroupQueue::pop_filled(int timeout_ms) {
  std::unique_lock lock(mutex_);
  filled_cv_.wait_for(lock, std::chrono::milliseconds(timeout_ms),
                      [this] { return !filled_.empty() || closed_; });
  if (filled_.empty()) return std::nullopt;
  const std::size_t index = filled_.front();
  filled_.pop_front();
  return index;
}

void GroupQueue::release(std::size_t index) {
  std::lock_guard lock(mutex_);
  free_.push_back(index);
}

void GroupQueue::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  filled_cv_.notify_all();
}

bool GroupQueue::closed_and_drained() {
  std::lock_guard lock(mutex_);
  return closed_ && filled_.empty();
}

std::size_t GroupQueue::queued() {
  std::lock_guard lock(mutex_);
  return filled_.size();
}

}  // namespace ioct::ringrec
