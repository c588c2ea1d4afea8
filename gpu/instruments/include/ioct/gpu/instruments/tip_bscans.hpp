// The instrument-tracked B-scan pair (El-Haddad and Tao): two B-scans through the tip, one along
// the instrument's axis and one across it, cut from the volume already acquired, so they follow
// the tool with no change of the scan. Each is centred on the tip, spans `half_width_um` either
// side of it at the A-scan spacing, and takes the volume's whole depth; lateral positions between
// voxels are interpolated bilinearly, positions outside the field are black.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/gpu/segmentation/segmentation_config.hpp"
#include "ioct/gpu/volume/volume.hpp"

namespace ioct::gpu::instruments {

struct TipBscans {
  std::uint32_t width = 0;   // columns of each B-scan; the tip lies in column width / 2
  std::uint32_t height = 0;  // depth px (the volume's)
  // Row-major grey, the two side by side: [row][along columns | across columns].
  std::vector<std::uint8_t> pixels;
  std::uint32_t stride() const noexcept { return 2 * width; }
};

inline constexpr double kTipBscanHalfWidthUm = 1500.0;

// Cuts the pair through `tip` from `volume` ([bscan][ascan][depth]) into `out` (its memory
// reused). Across is the axis turned by +90 degrees en face.
void cut_tip_bscans(const Volume& volume, const InstrumentTip& tip,
                    const segmentation::VolumeSampling& sampling, TipBscans& out,
                    double half_width_um = kTipBscanHalfWidthUm);

}  // namespace ioct::gpu::instruments
