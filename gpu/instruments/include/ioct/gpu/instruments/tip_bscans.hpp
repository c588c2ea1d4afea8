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
#include "ioct/gpu/volume/volume_ref.hpp"

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
// reused). Across is the axis turned by +90 degrees en face. A device ref (CUDA builds) is cut on
// the device, after the work on its stream, and only the pair comes to the host; the pixels are
// the host's (tip_cut.hpp).
void cut_tip_bscans(VolumeRef volume, const InstrumentTip& tip,
                    const segmentation::VolumeSampling& sampling, TipBscans& out,
                    double half_width_um = kTipBscanHalfWidthUm);
inline void cut_tip_bscans(const Volume& volume, const InstrumentTip& tip,
                           const segmentation::VolumeSampling& sampling, TipBscans& out,
                           double half_width_um = kTipBscanHalfWidthUm) {
  cut_tip_bscans(VolumeRef::on_host(volume), tip, sampling, out, half_width_um);
}

}  // namespace ioct::gpu::instruments
