// The instrument's figures for /metrics, from the newest frame of the shared view (the tip nearest
// to the RPE, as the page shows it). Written only while ioct-gpu runs with instrument detection:
// a stopped pipeline's last distance is never served as current. Names: docs/metrics.md.
#pragma once

#include <string>

#include "ioct/shm/frame_ring.hpp"

namespace ioct::view {

void write_instrument_metrics(const shm::FrameInstrument& instrument, bool gpu_up,
                              std::string& out);

}  // namespace ioct::view
