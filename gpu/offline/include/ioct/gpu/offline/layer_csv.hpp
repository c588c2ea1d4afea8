// The segmentation lines of a .vol file as CSV, one row per A-scan of every B-scan:
//   bscan,ascan,ILM_px,BM_px,RNFL_px,ILM_um,BM_um,RNFL_um
// depths from the top of the B-scan in pixels (as stored) and in micrometres (pixels x the
// axial spacing); an empty cell where the device drew no line.
#pragma once

#include <cstdio>
#include <string>

#include "ioct/gpu/offline/heidelberg_vol.hpp"

namespace ioct::gpu::offline {

// Throws std::runtime_error when writing fails.
void write_layer_csv(std::FILE* stream, const HeidelbergVol& vol);

// The header row (without newline).
std::string layer_csv_header(const HeidelbergVol& vol);

}  // namespace ioct::gpu::offline
