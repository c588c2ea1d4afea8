// The instrument finding as a frame carries it (shm::FrameInstrument): the tool nearest to the
// RPE, so the page shows the distance that belongs to the picture beside it.
#pragma once

#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/gpu/render/render_params.hpp"
#include "ioct/shm/frame_ring.hpp"

namespace ioct::gpu::live {

// `findings` null: detection is off. `warn_rpe_um`: the warning distance detection was given.
// `render`: the camera of the frame's render (bake_params of its config), to place the tip in
// it; null: not placed.
shm::FrameInstrument frame_instrument(const instruments::InstrumentFindings* findings,
                                      double warn_rpe_um, const render::RenderParams* render);

}  // namespace ioct::gpu::live
