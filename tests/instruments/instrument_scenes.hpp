// The simulator's instrument scenes with their ground truth: a forceps, a needle and a scraper
// approaching the retina, touching it, indenting it and below its surface; each a small raster
// about the tool's tip at the default raster's spacing (11.7 um between A-scans, 47 um between
// B-scans), through the CPU chain (and the volume filters for the segmentation); beside it where
// the tip is (voxels, from the pose: sim::tip_voxel) and the ILM and RPE under the tip.
#pragma once

#include <string>
#include <vector>

#include "ioct/gpu/segmentation/segmentation_config.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/sim/instrument_truth.hpp"
#include "simulated_volume.hpp"

namespace ioct::instruments_test {

struct InstrumentScene {
  std::string name;
  sim::InstrumentKind kind = sim::InstrumentKind::forceps;
  float tip_x = 0.0f, tip_y = 0.0f;  // scan units
  double above_ilm_um = 0.0;         // the tip's depth: this far above the ILM (negative: below)
  float yaw_deg = 0.0f;
  float pitch_deg = 25.0f;
  float jaw_opening_deg = 0.0f;
};

struct SceneVolume {
  seg_test::SimulatedVolumeSpec spec;
  seg_test::SimulatedVolume volume;  // as processed (what the detection reads), with the truth
  gpu::Volume filtered;              // median + Gaussian (what the segmentation reads)
  gpu::segmentation::VolumeSampling sampling;
  sim::VoxelPoint tip;                     // truth (InstrumentModel::tip_state) of the first tool
  std::vector<sim::VoxelPoint> tool_tips;  // of every tool, in the spec's order
  double ilm_px = 0.0;                     // the truth surfaces under the tip (continuous)
  double rpe_px = 0.0;
  double to_ilm_um = 0.0;  // truth distances, signed as the detection's
  double to_rpe_um = 0.0;
};

// The scenes of the accuracy test.
std::vector<InstrumentScene> instrument_scenes();

// The volume of one scene: `ascans` x `bscans` about the tip at the default raster's spacing.
SceneVolume make_scene_volume(const InstrumentScene& scene, std::uint32_t ascans = 128,
                              std::uint32_t bscans = 32);

// The whole scan field (the simulator's default scan, `ascans` x `bscans`) with `tools` as posed,
// e.g. by ioct-rt's --sim-instrument; the truth is the first tool's at time 0, so the tools must
// stand still (no velocity, tremor or jaw cycle: std::invalid_argument).
SceneVolume make_field_volume(const std::vector<sim::InstrumentConfig>& tools, std::uint32_t ascans,
                              std::uint32_t bscans);

}  // namespace ioct::instruments_test
