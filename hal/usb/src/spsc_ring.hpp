// A single-producer single-consumer ring of trivially copyable items: one thread pushes, one
// other thread pops, neither locks nor allocates after reset().
#pragma once

#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <type_traits>

namespace ioct::hal::usb::detail {

template <typename T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  // Allocates room for at least `capacity` items and empties the ring. Not concurrent with
  // push or pop.
  void reset(std::size_t capacity) {
    capacity_ = std::bit_ceil(capacity < 2 ? std::size_t{2} : capacity);
    items_ = std::make_unique<T[]>(capacity_);
    head_.store(0, std::memory_order_relaxed);
    tail_.store(0, std::memory_order_relaxed);
  }

  std::size_t capacity() const noexcept { return capacity_; }

  // Producer side.
  bool push(const T& item) noexcept {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_.load(std::memory_order_acquire) >= capacity_) return false;
    items_[tail & (capacity_ - 1)] = item;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer side.
  bool pop(T& item) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) return false;
    item = items_[head & (capacity_ - 1)];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Either side: items queued now (a snapshot).
  std::size_t size() const noexcept {
    return static_cast<std::size_t>(tail_.load(std::memory_order_acquire) -
                                    head_.load(std::memory_order_acquire));
  }

 private:
  std::unique_ptr<T[]> items_;
  std::size_t capacity_ = 0;
  alignas(64) std::atomic<std::uint64_t> head_{0};
  alignas(64) std::atomic<std::uint64_t> tail_{0};
};

}  // namespace ioct::hal::usb::detail
