// Presses of the footswitch, counted where the line is read: the safety thread, at every poll
// (1 ms) and every input edge. Others (ioct-view, over the status) take the count's difference,
// so a tap shorter than their status poll is not lost. A press is the line going down after it
// was up for the debounce time: a mechanical switch bounces for a few ms at each press and
// release, and a surgeon's next press comes hundreds of ms later. Pure, no allocation (RT).
#pragma once

#include <cstdint>

namespace ioct::rt {

class FootswitchPresses {
 public:
  static constexpr std::uint64_t kDebounceNs = 20'000'000;

  // The line as read at `now_ns` (CLOCK_MONOTONIC). The first reading sets the state without
  // counting: a pedal held down at start-up was not pressed now.
  void observe(bool down, std::uint64_t now_ns) noexcept {
    if (!seen_) {
      seen_ = true;
      down_ = down;
      released_ns_ = now_ns;
      return;
    }
    if (down && !down_ && now_ns - released_ns_ >= kDebounceNs) ++presses_;
    if (!down && down_) released_ns_ = now_ns;
    down_ = down;
  }

  std::uint64_t presses() const noexcept { return presses_; }

 private:
  bool seen_ = false;
  bool down_ = false;
  std::uint64_t released_ns_ = 0;  // when the line last went up
  std::uint64_t presses_ = 0;
};

}  // namespace ioct::rt
