// Follows ioct-gpu's frame ring on a thread of its own: attaches when the ring appears, reattaches
// when its writer is replaced, reads every new frame as the writer wakes it (the newest of each
// view wins downstream) and judges the signal 20 times a second. It only reads shared memory:
// nothing it does can slow the writer.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "ioct/shm/frame_ring.hpp"
#include "signal_verdict.hpp"

namespace ioct::view {

struct FollowerSnapshot {
  bool attached = false;
  SignalVerdict verdict;
  shm::FrameRingStatus status{};
  shm::FrameWriterHealth health;
  // The writer runs and beats within the policy's bound: its status is current.
  bool writer_responding = false;
  std::uint64_t frames_read = 0;
  std::uint64_t frames_skipped = 0;  // overwritten before this reader copied them
  std::uint64_t attaches = 0;
  std::string attach_error;  // why the ring is not attached, while it is not
};

class FrameFollower {
 public:
  // Both run on the follower's thread; they must hand over quickly (post to an io_context).
  using FrameCallback = std::function<void(std::shared_ptr<const shm::Frame>)>;
  using TickCallback = std::function<void(const FollowerSnapshot&)>;

  FrameFollower(std::string ring_name, StalePolicy policy, FrameCallback on_frame,
                TickCallback on_tick);
  ~FrameFollower();
  FrameFollower(const FrameFollower&) = delete;
  FrameFollower& operator=(const FrameFollower&) = delete;

  // Frames come as the writer wakes the follower (FrameRingReader::wait_for_frame).
  static constexpr std::uint64_t kTickNs = 50'000'000;     // signal judged 20 times a second
  static constexpr std::uint64_t kAttachNs = 200'000'000;  // retry to attach

 private:
  void run();

  const std::string ring_name_;
  const StalePolicy policy_;
  FrameCallback on_frame_;
  TickCallback on_tick_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace ioct::view
