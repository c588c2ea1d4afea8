// A bounded single-producer single-consumer queue: one thread pushes, one other thread pops,
// neither waits, allocates or locks. The hand-over between the housekeeping thread and the
// acquisition thread (new scan patterns one way, retired ones and log events the other) goes
// through these.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <optional>
#include <type_traits>

namespace ioct::rt {

template <typename T, std::size_t Capacity>
class SpscQueue {
  static_assert(Capacity >= 1);
  static_assert(std::is_trivially_copyable_v<T>, "items are copied between threads as they are");

 public:
  // Producer side. False when the queue is full (the item is not taken).
  bool push(const T& item) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_.load(std::memory_order_acquire) == Capacity) return false;
    items_[tail % Capacity] = item;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer side. Empty optional when there is nothing.
  std::optional<T> pop() noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) return std::nullopt;
    T item = items_[head % Capacity];
    head_.store(head + 1, std::memory_order_release);
    return item;
  }

  // Either side: items queued at the moment of the call (a snapshot).
  std::size_t size() const noexcept {
    return tail_.load(std::memory_order_acquire) - head_.load(std::memory_order_acquire);
  }
  bool empty() const noexcept { return size() == 0; }
  static constexpr std::size_t capacity() noexcept { return Capacity; }

 private:
  std::array<T, Capacity> items_{};
  alignas(64) std::atomic<std::size_t> head_{0};  // next to pop; written by the consumer
  alignas(64) std::atomic<std::size_t> tail_{0};  // next to fill; written by the producer
};

}  // namespace ioct::rt
