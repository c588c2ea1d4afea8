// A bounded single-producer single-consumer queue: one thread pushes, one other thread pops,
// neither waits, locks or allocates. The memory is allocated once, by the constructor, so the
// real-time thread may push and pop after start-up.
//
// After rigtorp's SPSCQueue: each side keeps a cached copy of the other side's index and reads
// the shared one only when the cache says full (producer) or empty (consumer), so in the steady
// state each side touches only its own cache lines. After folly's ProducerConsumerQueue: the
// producer's and the consumer's words sit kFalseSharingRange apart, and the slots are padded at
// both ends, so neither queue nor slot array shares a line with a neighbour written by another
// thread.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "ioct/concurrency/false_sharing.hpp"

namespace ioct {

template <typename T>
class SpscQueue {
  static_assert(std::is_nothrow_destructible_v<T>);
  static_assert(std::is_nothrow_move_constructible_v<T>,
                "pop() moves the item out and must not fail half-way");

 public:
  // Room for exactly `capacity` items. Throws std::invalid_argument for 0 and std::length_error
  // when the slots would not fit in memory.
  explicit SpscQueue(std::size_t capacity) : slots_(checked_slots(capacity)) {
    storage_ = std::allocator<T>{}.allocate(slots_ + 2 * kPadding);
  }
  ~SpscQueue() {
    while (front() != nullptr) drop_front();
    std::allocator<T>{}.deallocate(storage_, slots_ + 2 * kPadding);
  }
  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  // Producer side. False when the queue is full: the item is not taken (nor moved from).
  template <typename... Args>
  [[nodiscard]] bool emplace(Args&&... args) noexcept(
      std::is_nothrow_constructible_v<T, Args&&...>) {
    const std::size_t write = write_.load(std::memory_order_relaxed);
    const std::size_t next = following(write);
    if (next == cached_read_) {
      cached_read_ = read_.load(std::memory_order_acquire);
      if (next == cached_read_) return false;
    }
    ::new (static_cast<void*>(slot(write))) T(std::forward<Args>(args)...);
    write_.store(next, std::memory_order_release);
    return true;
  }
  [[nodiscard]] bool push(const T& item) noexcept(std::is_nothrow_copy_constructible_v<T>) {
    return emplace(item);
  }
  [[nodiscard]] bool push(T&& item) noexcept { return emplace(std::move(item)); }

  // Consumer side. False (and `out` untouched) when the queue is empty.
  [[nodiscard]] bool pop(T& out) noexcept(std::is_nothrow_move_assignable_v<T>) {
    T* item = front();
    if (item == nullptr) return false;
    out = std::move(*item);
    drop_front();
    return true;
  }
  // Consumer side. Empty when the queue is empty.
  [[nodiscard]] std::optional<T> pop() noexcept {
    T* item = front();
    if (item == nullptr) return std::nullopt;
    std::optional<T> out(std::move(*item));
    drop_front();
    return out;
  }

  // Either side: the items queued at the moment of the call (a snapshot, stale once returned).
  std::size_t size() const noexcept {
    const std::size_t write = write_.load(std::memory_order_acquire);
    const std::size_t read = read_.load(std::memory_order_acquire);
    return write >= read ? write - read : write + slots_ - read;
  }
  bool empty() const noexcept { return size() == 0; }
  std::size_t capacity() const noexcept { return slots_ - 1; }

 private:
  // Slots kept free before and after the used ones, so the first and last items do not share a
  // cache line with whatever the allocator placed next to the array.
  static constexpr std::size_t kPadding = (kFalseSharingRange - 1) / sizeof(T) + 1;

  // One slot more than the capacity: a full queue keeps one slot free, so full and empty differ.
  static std::size_t checked_slots(std::size_t capacity) {
    if (capacity == 0) throw std::invalid_argument("SpscQueue capacity = 0: must be at least 1");
    if (capacity > std::allocator_traits<std::allocator<T>>::max_size(std::allocator<T>{}) -
                       2 * kPadding - 1) {
      throw std::length_error("SpscQueue capacity = " + std::to_string(capacity) +
                              ": too many items to allocate");
    }
    return capacity + 1;
  }
  std::size_t following(std::size_t index) const noexcept {
    return index + 1 == slots_ ? 0 : index + 1;
  }
  T* slot(std::size_t index) const noexcept { return storage_ + kPadding + index; }

  // Consumer side: the oldest item, or null when empty.
  T* front() noexcept {
    const std::size_t read = read_.load(std::memory_order_relaxed);
    if (read == cached_write_) {
      cached_write_ = write_.load(std::memory_order_acquire);
      if (read == cached_write_) return nullptr;
    }
    return std::launder(slot(read));
  }
  void drop_front() noexcept {
    const std::size_t read = read_.load(std::memory_order_relaxed);
    std::destroy_at(std::launder(slot(read)));
    read_.store(following(read), std::memory_order_release);
  }

  // Set at construction, read by both sides.
  const std::size_t slots_;
  T* storage_ = nullptr;
  // The producer's line: its index (read by the consumer) ...
  alignas(kFalseSharingRange) std::atomic<std::size_t> write_{0};
  // ... its private copy of the consumer's index ...
  alignas(kFalseSharingRange) std::size_t cached_read_ = 0;
  // ... the consumer's index (read by the producer) ...
  alignas(kFalseSharingRange) std::atomic<std::size_t> read_{0};
  // ... and its private copy of the producer's index. The class's alignment pads the end.
  alignas(kFalseSharingRange) std::size_t cached_write_ = 0;
};

}  // namespace ioct
