// Device results brought to the host through one pinned block: a copy into pageable memory is
// synchronous and several times slower (a 128 x 512 volume's surfaces: 0.61 ms pageable, 0.19 ms
// pinned, H100 host), and every live pass with instruments brings several back.
//
// Usage: add() the device ranges, fetch() on the stream that wrote them (one synchronisation;
// or enqueue() now and wait() later), then read piece(i) or take() it into a host vector. The block
// is kept and grows, never shrinks, so a steady stream of equal downloads allocates nothing after
// the first.
#pragma once

#include <array>
#include <cstddef>
#include <cstring>
#include <optional>
#include <span>
#include <stdexcept>
#include <utility>
#include <vector>

#include "ioct/gpu/cuda/cuda_support.hpp"

namespace ioct::gpu::cuda {

class PinnedDownload {
 public:
  static constexpr std::size_t kMaxPieces = 8;
  // Every piece starts at a multiple of this in the block, so a float piece after a byte piece
  // is read aligned.
  static constexpr std::size_t kAlignment = 16;

  // Queues `bytes` from `device` (not copied until fetch() or enqueue()); returns the piece's
  // index. The first add() after a download begins the next one: the last one's pieces are gone.
  std::size_t add(const void* device, std::size_t bytes) {
    fetched_ = 0;
    if (in_flight_) throw std::logic_error("PinnedDownload: a download is in flight");
    if (count_ == kMaxPieces) throw std::logic_error("PinnedDownload: more than 8 pieces");
    const std::size_t offset = count_ == 0 ? 0 : aligned(end_of(count_ - 1));
    pieces_[count_] = {device, offset, bytes};
    return count_++;
  }

  // Copies every queued piece on `stream` into the block and waits for them. The queue is
  // emptied whatever happens (a failed download leaves nothing behind for the next one); the
  // pieces stay readable until the next add().
  void fetch(cudaStream_t stream, Payload payload, const char* what) {
    enqueue(stream, payload, what);
    wait();
  }

  // fetch() in two halves, for a host with work to do while the copies run: enqueue() queues
  // them on `stream` (the queue emptied whatever happens), wait() waits for that stream and makes
  // the pieces readable. Nothing is readable in between, and the block is not to be touched:
  // another add() or enqueue() before wait() throws, as does a wait() with nothing enqueued.
  void enqueue(cudaStream_t stream, Payload payload, const char* what) {
    fetched_ = 0;
    if (in_flight_) throw std::logic_error("PinnedDownload: a download is in flight");
    const std::size_t count = std::exchange(count_, 0);
    const std::size_t total = count == 0 ? 0 : end_of(count - 1);
    block_.resize(total);  // within its allocation after the largest download so far
    for (std::size_t i = 0; i < count; ++i) {
      if (pieces_[i].bytes == 0) continue;
      copy_async(block_.data() + pieces_[i].offset, pieces_[i].device, pieces_[i].bytes,
                 cudaMemcpyDeviceToHost, stream, payload, what);
    }
    in_flight_ = count;
    stream_ = stream;
  }
  void wait() {
    if (!in_flight_) throw std::logic_error("PinnedDownload: wait() with nothing enqueued");
    const std::size_t count = *std::exchange(in_flight_, std::nullopt);
    IOCT_CUDA_CHECK(cudaStreamSynchronize(stream_));
    fetched_ = count;
  }
  // Whether an enqueue() waits for its wait().
  bool in_flight() const noexcept { return in_flight_.has_value(); }

  // The bytes of piece `i` of the last download (fetch(), or enqueue() and wait()).
  std::span<const std::byte> piece(std::size_t i) const {
    if (i >= fetched_) throw std::logic_error("PinnedDownload: no such piece fetched");
    return {block_.data() + pieces_[i].offset, pieces_[i].bytes};
  }

  // Piece `i` as the whole of `values` (resized to the piece's element count).
  template <class T>
  void take(std::size_t i, std::vector<T>& values) const {
    const std::span<const std::byte> bytes = piece(i);
    if (bytes.size() % sizeof(T) != 0) {
      throw std::logic_error("PinnedDownload: a piece is not a whole number of values");
    }
    values.resize(bytes.size() / sizeof(T));
    if (!bytes.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(T));
  }

 private:
  struct Piece {
    const void* device = nullptr;
    std::size_t offset = 0, bytes = 0;
  };
  static std::size_t aligned(std::size_t offset) {
    return (offset + kAlignment - 1) / kAlignment * kAlignment;
  }
  std::size_t end_of(std::size_t i) const { return pieces_[i].offset + pieces_[i].bytes; }

  PinnedArray<std::byte> block_;
  std::array<Piece, kMaxPieces> pieces_{};
  std::size_t count_ = 0;
  std::size_t fetched_ = 0;
  std::optional<std::size_t> in_flight_;  // pieces enqueued and not waited for
  cudaStream_t stream_ = nullptr;         // theirs
};

}  // namespace ioct::gpu::cuda
