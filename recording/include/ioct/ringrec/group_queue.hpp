// The bounded hand-over between the ring reader and the disk writer: a fixed pool of group
// buffers, allocated once. The reader takes a free buffer without waiting (none free: the group
// is dropped and counted, the reader never waits for the disk); the writer waits for filled ones.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <vector>

#include "ioct/shm/ring_layout.hpp"

namespace ioct::ringrec {

struct GroupBuffer {
  shm::SlotHeader header{};
  std::vector<std::byte> payload;
};

class GroupQueue {
 public:
  // `capacity` buffers of `group_bytes` each, touched once so the first groups do not fault.
  GroupQueue(std::size_t capacity, std::uint64_t group_bytes);

  // Reader side. nullopt when every buffer is queued or being written.
  std::optional<std::size_t> try_take_free();
  void give_back_free(std::size_t index);  // not filled after all (the copy was lapped)
  void push_filled(std::size_t index);

  // Writer side. Waits until a buffer is filled, the queue is closed (nullopt once drained) or
  // `timeout_ms` passes (nullopt, not closed).
  std::optional<std::size_t> pop_filled(int timeout_ms);
  void release(std::size_t index);  // written: free again
  // No more buffers will be filled; pop_filled() drains what is queued, then returns nullopt.
  void close();
  bool closed_and_drained();

  GroupBuffer& buffer(std::size_t index) { return buffers_[index]; }
  std::size_t capacity() const noexcept { return buffers_.size(); }
  std::size_t queued();

 private:
  std::vector<GroupBuffer> buffers_;
  std::mutex mutex_;
  std::condition_variable filled_cv_;
  std::vector<std::size_t> free_;
  std::deque<std::size_t> filled_;
  bool closed_ = false;
};

}  // namespace ioct::ringrec
