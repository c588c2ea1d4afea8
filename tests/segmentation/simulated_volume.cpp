#include "simulated_volume.hpp"

#include <algorithm>
#include <stdexcept>

#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/processing/cpu_oct_processor.hpp"
#include "ioct/gpu/volume/processed_group.hpp"
#include "ioct/sim/simulated_digitizer.hpp"

namespace ioct::seg_test {

SimulatedVolume make_simulated_volume(const SimulatedVolumeSpec& spec) {
  if (spec.bscans % spec.bscans_per_group != 0) {
    throw std::invalid_argument("bscans must be a multiple of bscans_per_group");
  }
  hal::DigitizerConfig acquisition;
  acquisition.samples_per_ascan = spec.samples_per_ascan;
  acquisition.ascans_per_bscan = spec.ascans;
  acquisition.flyback_sweeps = 4;
  acquisition.bscans_per_group = spec.bscans_per_group;
  sim::SimulationConfig simulation = spec.simulation;
  simulation.scan.ascans_per_bscan = spec.ascans;
  simulation.scan.bscans_per_volume = spec.bscans;
  sim::SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(acquisition);
  digitizer.start();

  shm::RingGeometry geometry;
  geometry.samples_per_ascan = spec.samples_per_ascan;
  geometry.ascans_per_bscan = spec.ascans;
  geometry.bscans_per_group = spec.bscans_per_group;
  geometry.bscans_per_volume = spec.bscans;
  gpu::OctProcessorConfig config;
  config.fft.rigor = gpu::FftRigor::estimate;
  config.threads = 1;
  gpu::CpuOctProcessor processor(config);
  processor.prepare(geometry);

  SimulatedVolume result;
  const std::size_t ascans_per_volume = std::size_t{spec.bscans} * spec.ascans;
  result.ilm_truth.resize(ascans_per_volume);
  result.rpe_truth.resize(ascans_per_volume);
  result.tool_truth.resize(ascans_per_volume);
  const std::uint32_t depth = spec.samples_per_ascan / 2;
  gpu::Volume raw(spec.bscans, spec.ascans, depth);
  std::vector<std::uint16_t> payload(acquisition.samples_per_group());
  gpu::ProcessedGroup processed;
  for (std::uint32_t first = 0; first < spec.bscans; first += spec.bscans_per_group) {
    hal::GroupInfo info;
    digitizer.acquire_group(payload, info);
    shm::SlotHeader header{};
    header.group_index = first / spec.bscans_per_group;
    header.payload_bytes = geometry.group_payload_bytes();
    header.bscan_count = spec.bscans_per_group;
    header.active_ascan_begin = 0;
    header.active_ascan_end = spec.ascans;
    for (std::uint32_t b = 0; b < spec.bscans_per_group; ++b) {
      shm::BscanMarker& marker = header.bscans[b];
      marker.bscan_in_volume = first + b;
      if (first + b == 0) marker.flags |= shm::kBscanVolumeStart;
      if (first + b + 1 == spec.bscans) marker.flags |= shm::kBscanVolumeEnd;
    }
    processor.process(gpu::RawGroup{header, payload}, processed);
    // Where the layers were drawn in this group (instruments move, the beam may lag).
    const sim::GroupTruth& truth = digitizer.last_group_truth();
    const std::size_t offset = std::size_t{first} * spec.ascans;
    std::copy(truth.ilm_px.begin(), truth.ilm_px.end(), result.ilm_truth.begin() + offset);
    std::copy(truth.rpe_px.begin(), truth.rpe_px.end(), result.rpe_truth.begin() + offset);
    std::copy(truth.tool_px.begin(), truth.tool_px.end(), result.tool_truth.begin() + offset);
    for (std::uint32_t b = 0; b < spec.bscans_per_group; ++b) {
      const auto src = processed.bscan(b);
      std::copy(src.begin(), src.end(), raw.bscan(first + b).begin());
    }
  }
  if (spec.filter) {
    const auto filter = gpu::filters::make_volume_filter(gpu::Backend::cpu, {}, 1);
    filter->filter_volume(raw, result.volume);
  } else {
    result.volume = std::move(raw);
  }

  result.axial_um_per_px = simulation.source.axial_pixel_um();
  return result;
}

gpu::segmentation::VolumeSampling sampling_of(const SimulatedVolumeSpec& spec,
                                              const SimulatedVolume& volume) {
  const double field_um = 2000.0 * spec.simulation.field_half_width_mm();
  gpu::segmentation::VolumeSampling s;
  s.axial_um_per_px = volume.axial_um_per_px;
  s.ascan_spacing_um = field_um * spec.simulation.scan.extent_x / (spec.ascans - 1);
  s.bscan_spacing_um = field_um * spec.simulation.scan.extent_y / (spec.bscans - 1);
  return s;
}

}  // namespace ioct::seg_test
