#include "frame_follower.hpp"

#include <algorithm>
#include <chrono>
#include <optional>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/ring_error.hpp"

namespace ioct::view {

FrameFollower::FrameFollower(std::string ring_name, StalePolicy policy, FrameCallback on_frame,
                             TickCallback on_tick)
    : ring_name_(std::move(ring_name)),
      policy_(policy),
      on_frame_(std::move(on_frame)),
      on_tick_(std::move(on_tick)) {
  thread_ = std::thread([this] { run(); });
}

FrameFollower::~FrameFollower() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
}

void FrameFollower::run() {
  std::optional<shm::FrameRingReader> reader;
  FollowerSnapshot snap;
  std::uint64_t next_attach_ns = 0;
  std::uint64_t next_tick_ns = 0;
  auto frame = std::make_shared<shm::Frame>();
  bool woken = false;  // the last wait ended with news from the writer
  while (!stop_.load(std::memory_order_relaxed)) {
    const std::uint64_t now = ioct::monotonic_ns();
    if (!reader && now >= next_attach_ns) {
      next_attach_ns = now + kAttachNs;
      try {
        reader.emplace(shm::FrameRingReader::attach(ring_name_));
        ++snap.attaches;
        snap.attach_error.clear();
      } catch (const shm::RingError& e) {
        snap.attach_error = e.what();
      }
    }
    if (reader) {
      bool read_one = false;
      while (reader->read_next(*frame)) {
        read_one = true;
        ++snap.frames_read;
        on_frame_(std::move(frame));
        frame = std::make_shared<shm::Frame>();
      }
      snap.frames_skipped = reader->frames_skipped();
      // News but no frame: the writer closed the ring (or lapped a copy). Judged now, not at the
      // next tick, and not woken again and again until then.
      if (woken && !read_one) next_tick_ns = now;
    }
    if (now >= next_tick_ns) {
      next_tick_ns = now + kTickNs;
      SignalInputs in;
      in.now_ns = now;
      in.attached = reader.has_value();
      if (reader) {
        in.health = reader->health();
        for (int tries = 0; tries < 3 && !reader->read_status(in.status); ++tries) {
        }
        if (!in.health.alive) {
          // Closed or its writer died: a restarted ioct-gpu makes a new object under the name.
          reader.reset();
          next_attach_ns = now;
        }
      }
      // The age is judged after the status was read, so it is never shown younger than it is.
      in.now_ns = ioct::monotonic_ns();
      snap.attached = in.attached;
      snap.health = in.health;
      snap.writer_responding =
          in.attached && in.health.alive &&
          static_cast<double>(in.health.heartbeat_age_ns) * 1e-9 <= policy_.writer_silent_s;
      snap.status = in.status;
      snap.verdict = judge_signal(in, policy_);
      on_tick_(snap);
    }
    // Asleep until the next frame (the writer wakes us), the next judgement or the next try to
    // attach, whichever comes first.
    const std::uint64_t after = ioct::monotonic_ns();
    const std::uint64_t until = reader ? next_tick_ns : std::min(next_tick_ns, next_attach_ns);
    const std::uint64_t rest = until > after ? until - after : 0;
    woken = false;
    if (reader) {
      woken = reader->wait_for_frame(rest);
    } else {
      std::this_thread::sleep_for(std::chrono::nanoseconds(rest));
    }
  }
}

}  // namespace ioct::view
