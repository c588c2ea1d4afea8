// The tip's B-scan pair cut on the device (CUDA builds): the kernel of tip_cut.hpp's arithmetic.
#pragma once

#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/instruments/tip_cut.hpp"

namespace ioct::gpu::instruments {

// `out` sized by the caller (width, height, pixels); `volume` a device ref.
void cut_tip_bscans_on_device(const VolumeRef& volume, const TipCut& cut, TipBscans& out);

}  // namespace ioct::gpu::instruments
