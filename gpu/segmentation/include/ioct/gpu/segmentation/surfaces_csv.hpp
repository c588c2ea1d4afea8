// The surfaces as CSV, one row per A-scan of every B-scan:
//   bscan,ascan,state,confidence,ilm_px,rpe_px,bm_px,ilm_um,rpe_um,bm_um
// state is measured, bridged or none; depths from the top of the B-scan in px (fractional) and
// in micrometres (px x the axial spacing); empty cells where a surface is NaN.
#pragma once

#include <cstdio>
#include <string_view>

#include "ioct/gpu/segmentation/surfaces.hpp"

namespace ioct::gpu::segmentation {

std::string_view to_string(SurfaceState state) noexcept;
std::string_view to_string(BscanVerdict verdict) noexcept;

// Throws std::runtime_error when writing fails.
void write_surfaces_csv(std::FILE* stream, const Surfaces& surfaces, double axial_um_per_px);

}  // namespace ioct::gpu::segmentation
