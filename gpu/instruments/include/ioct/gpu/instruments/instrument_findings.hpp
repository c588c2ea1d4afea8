// What the detection found in one volume: per A-scan whether an instrument shadows it (the
// shadow mask: the one home of "this A-scan is under a tool" for every later stage) and the depth
// of the tool's reflex there; per instrument its tip in volume coordinates and the signed
// distances from the tip to the ILM and to the RPE.
//
// Volume coordinates: voxels [bscan][ascan][depth] (fractional), and um from the volume's first
// voxel (x along a B-scan = ascan x ascan spacing, y across B-scans = bscan x bscan spacing,
// z = depth px x axial um per px, i.e. um of the depth axis as the sampling states it).
// Distances are um of the depth axis too, positive when the tip is above the surface (nearer the
// viewer), negative when it is below it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "ioct/gpu/instruments/column_classification.hpp"

namespace ioct::gpu::instruments {

// Where the surfaces at the tip came from.
enum class DistanceSource : std::uint8_t {
  none = 0,      // no segmented surface anywhere near: distances NaN
  measured = 1,  // the tip's own A-scan is unshadowed and measured by the segmentation
  inferred = 2,  // under the tool: interpolated from the nearest unshadowed measured A-scans
};

std::string_view to_string(DistanceSource source) noexcept;

struct InstrumentTip {
  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

  std::uint32_t footprint_ascans = 0;  // A-scans of its shadow mask
  bool translucent = false;            // the tip's A-scans are partly shadowed (the paddle)
  double bscan = 0.0, ascan = 0.0, depth_px = 0.0;  // voxels
  double x_um = 0.0, y_um = 0.0, z_um = 0.0;        // um from the first voxel
  // The instrument's axis en face (unit, in um): from the shaft towards the tip.
  double axis_x = 1.0, axis_y = 0.0;
  double ilm_px = kNone, rpe_px = kNone;        // the surfaces at the tip's lateral position
  double to_ilm_um = kNone, to_rpe_um = kNone;  // signed, see above
  DistanceSource source = DistanceSource::none;
};

struct InstrumentFindings {
  static constexpr std::size_t kMaxInstruments = 4;

  std::uint32_t bscans = 0;
  std::uint32_t ascans = 0;
  // [bscan][ascan]: each A-scan as classified on its own, and the shadow mask: those of them
  // with at least kMinMaskedNeighbours of their 8 neighbours classified so too (a lone A-scan
  // is speckle, not a tool) that belong to an instrument's footprint (tip_finder.hpp).
  static constexpr int kMinMaskedNeighbours = 3;
  std::vector<ColumnKind> columns;
  std::vector<ColumnKind> mask;
  std::vector<float> reflex_px;     // [bscan][ascan]; 0 where clear
  std::vector<float> front_px;      // [bscan][ascan]; a translucent tool's front, 0 elsewhere
  std::vector<std::uint8_t> floor;  // [bscan]: the noise floor found (u8)
  std::vector<InstrumentTip> tips;  // largest footprint first, at most kMaxInstruments
  // The index in tips of the one nearest to the RPE (smallest to_rpe_um; without distances, the
  // largest footprint), -1 for none; and whether it is within the warning distance of the RPE.
  std::int32_t nearest = -1;
  bool warning = false;

  void reset(std::uint32_t bscan_count, std::uint32_t ascan_count) {
    bscans = bscan_count;
    ascans = ascan_count;
    const std::size_t n = std::size_t{bscan_count} * ascan_count;
    columns.assign(n, ColumnKind::clear);
    mask.assign(n, ColumnKind::clear);
    reflex_px.assign(n, 0.0f);
    front_px.assign(n, 0.0f);
    floor.assign(bscan_count, 0);
    tips.clear();
    nearest = -1;
    warning = false;
  }
  std::size_t index(std::uint32_t bscan, std::uint32_t ascan) const noexcept {
    return std::size_t{bscan} * ascans + ascan;
  }
  std::size_t size() const noexcept { return std::size_t{bscans} * ascans; }
  const InstrumentTip* nearest_tip() const noexcept {
    return nearest >= 0 ? &tips[static_cast<std::size_t>(nearest)] : nullptr;
  }
};

// "forceps-like tip at (b, a, d) vox ... ILM +120 um (inferred)": one line for the live summary.
std::string describe(const InstrumentFindings& findings);

}  // namespace ioct::gpu::instruments
