// Volumes with ground truth for the segmentation tests: the simulated retina acquired group by
// group, processed by the CPU chain (CpuOctProcessor), placed into a volume and filtered (median
// 3x3x3 + Gaussian 5x5), as the live pipeline does; beside it the simulator's ILM and RPE depth
// for every A-scan.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/gpu/segmentation/segmentation_config.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/sim/simulation_config.hpp"

namespace ioct::seg_test {

struct SimulatedVolumeSpec {
  std::uint32_t samples_per_ascan = 1376;
  std::uint32_t ascans = 256;
  std::uint32_t bscans = 32;
  std::uint32_t bscans_per_group = 16;
  sim::SimulationConfig simulation;  // scan.ascans_per_bscan / bscans_per_volume are set from above
  bool filter = true;                // median + Gaussian as the live pipeline does
};

struct SimulatedVolume {
  gpu::Volume volume;
  std::vector<float> ilm_truth;  // [bscan][ascan], px; NaN where absent
  std::vector<float> rpe_truth;
  std::vector<float> tool_truth;  // depth of an instrument's surface; NaN where none
  double axial_um_per_px = 0.0;   // optical path per depth px
};

// Throws what the simulator or the chain throw for a bad spec.
SimulatedVolume make_simulated_volume(const SimulatedVolumeSpec& spec);

// The sampling the segmenter is given for such a volume: its depth px and the scan's lateral
// spacing of A-scans and B-scans over the simulated field.
gpu::segmentation::VolumeSampling sampling_of(const SimulatedVolumeSpec& spec,
                                              const SimulatedVolume& volume);

}  // namespace ioct::seg_test
