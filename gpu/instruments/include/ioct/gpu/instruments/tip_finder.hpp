// From the shadow mask to tips and distances, on the host for both backends (the mask is a few
// hundred kB, the work per volume a few passes over it).
//
// 1. Footprints: 8-connected regions of masked A-scans; those smaller than min_ascans dropped,
//    the largest kMaxInstruments kept.
// 2. Axis: the principal direction of a footprint's A-scans in um. The shaft leaves the field,
//    so the tip is the end away from the footprint's A-scans on the volume's border (without
//    any, the end where the reflex lies deeper: the shaft rises towards the viewer).
// 3. Tip: the footprint's extreme along the axis is the rim of the tool's rounded end; the end's
//    centre lies its radius further in (half the footprint's width just behind the end), at the
//    reflex depth found there plus that radius in depth px (the reflex is the top of the end).
// 4. Distances: the ILM and RPE at the tip's lateral position. The tip's own A-scan is under the
//    tool; the surfaces come from the nearest unshadowed, measured A-scans along the B-scan and
//    across B-scans, interpolated linearly on either side (inferred), or from the A-scan itself
//    when it is unshadowed and measured (measured).
#pragma once

#include "ioct/gpu/instruments/instrument_config.hpp"
#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"

namespace ioct::gpu::instruments {

// Fills findings.tips, nearest and warning from findings.mask and reflex_px. `surfaces` of other
// dimensions than the mask (or empty) give tips without distances.
void find_tips(InstrumentFindings& findings, const segmentation::Surfaces& surfaces,
               const InstrumentConfig& config, const VolumeSampling& sampling);

}  // namespace ioct::gpu::instruments
