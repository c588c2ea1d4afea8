// What the instrument detection needs to know: the levels that tell a reflex, tissue and the
// noise floor apart in the filtered u8 volume, the sizes that tell a tool's reflex from the
// retina, and the warning threshold. The defaults suit the default geometry (688 px of 5.6 um,
// 512 A-scans over 6 mm) and the default dB window; see README.md.
#pragma once

#include <cstdint>

#include "ioct/gpu/segmentation/segmentation_config.hpp"  // VolumeSampling

namespace ioct::gpu::instruments {

using segmentation::VolumeSampling;

struct InstrumentConfig {
  // ioct-gpu runs the detection after the segmentation of every pass ("instruments.enabled",
  // --instruments).
  bool enabled = false;
  // The first px of every A-scan are not searched: the reference's DC residue lives there.
  std::uint32_t skip_top_px = 8;
  // u8 levels above the B-scan's noise floor (its median) at which a px holds something (a tool
  // or tissue) ...
  std::uint32_t object_margin = 40;
  // ... and at or below which it holds nothing (the vitreous, a shadow).
  std::uint32_t dark_margin = 8;
  // A run of dark px at least this long ends an object (um of the depth axis).
  double gap_um = 30.0;
  // A bright run of one A-scan longer than this is tissue, not a tool's reflex (um of the depth
  // axis): the retina with its choroid is hundreds of um deep, a metal reflex a few px.
  double max_reflex_um = 220.0;
  // A metal tool's shadow reaches the bottom of the A-scan; it must be at least this deep
  // (um of the depth axis), else the A-scan simply ended below a reflex.
  double min_shadow_um = 150.0;
  // A translucent tool (the scraper's paddle) is an object above a dark gap above the tissue,
  // whose peak is at least this many u8 levels above the floor.
  std::uint32_t partial_reflex_margin = 70;
  // ... and whose gap down to the tissue is at least this long (um of the depth axis) and nearly
  // empty.
  double partial_gap_um = 45.0;
  // Footprints smaller than this many A-scans are not instruments (speckle, a floater).
  std::uint32_t min_ascans = 12;
  // The medium the tool sits in (the vitreous): turns the lateral size of its end into depth px.
  double medium_group_index = 1.336;
  // The live summary warns when the tip is within this distance of the RPE (um, >= 0).
  double warn_rpe_um = 100.0;

  // Throws ConfigError naming the first bad key ("instruments.<key>").
  void validate() const;
};

}  // namespace ioct::gpu::instruments
