// The instrument finding as a frame carries it (shm::FrameInstrument): the tool nearest to the
// RPE, so the page shows the distance that belongs to the picture beside it.
#pragma once

#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/shm/frame_ring.hpp"

namespace ioct::gpu::live {

// `findings` null: detection is off. `warn_rpe_um`: the warning distance detection was given.
shm::FrameInstrument frame_instrument(const instruments::InstrumentFindings* findings,
                                      double warn_rpe_um) noexcept;

}  // namespace ioct::gpu::live
