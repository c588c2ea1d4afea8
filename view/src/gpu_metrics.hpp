// ioct-gpu's figures for /metrics, from what the frame follower last read of the frame ring's
// status (ioct-gpu keeps no web stack: the ring's header is its status object). While ioct-gpu is
// not running or not responding only ioct_gpu_up 0 is written: a stopped process's last figures
// are never shown as live. Names, types and units: docs/metrics.md.
#pragma once

#include <string>

#include "frame_follower.hpp"

namespace ioct::view {

void append_gpu_metrics(std::string& out, const FollowerSnapshot& follower);

}  // namespace ioct::view
