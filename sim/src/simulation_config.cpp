#include "ioct/sim/simulation_config.hpp"

#include <algorithm>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {

std::string_view to_string(SamplePreset preset) noexcept {
  switch (preset) {
    case SamplePreset::retina:
      return "retina";
    case SamplePreset::anterior_segment:
      return "anterior_segment";
    case SamplePreset::mirror:
      return "mirror";
  }
  return "unknown";
}

void SimulationConfig::validate() const {
  source.validate();
  interferometer.validate();
  detector.validate();
  switch (preset) {
    case SamplePreset::retina:
      retina.validate();
      break;
    case SamplePreset::anterior_segment:
      anterior.validate();
      break;
    case SamplePreset::mirror:
      mirror.validate();
      break;
    default:
      throw ioct::ConfigError("simulation.preset", ioct::format_value(std::uint64_t(preset)),
                              "must be retina, anterior_segment or mirror");
  }
  if (instruments.size() > kMaxInstruments) {
    throw ioct::ConfigError("simulation.instruments",
                            ioct::format_value(std::uint64_t{instruments.size()}) + " instruments",
                            "at most " + std::to_string(kMaxInstruments) + " are simulated");
  }
  for (std::size_t i = 0; i < instruments.size(); ++i) {
    instruments[i].validate("instruments[" + std::to_string(i) + "]");
  }
  if (workers > kMaxWorkers) {
    throw ioct::ConfigError(
        "simulation.workers", ioct::format_value(std::uint64_t{workers}),
        "must be 0 (synthesis on the acquisition thread) to " + std::to_string(kMaxWorkers));
  }
  if (worker_priority < 0 || worker_priority > 99) {
    throw ioct::ConfigError("simulation.worker_priority",
                            ioct::format_value(std::int64_t{worker_priority}),
                            "must be 0 (normal scheduling) or a SCHED_FIFO priority 1 to 99");
  }
  ioct::require_real_in_range("simulation.speckle_grain_um", speckle_grain_um, 0.5, 1000.0);
  bench.validate();
  scan.validate();
}

std::uint32_t SimulationConfig::default_workers(unsigned hardware_threads) noexcept {
  if (hardware_threads <= 4) return 1;
  return std::min(hardware_threads - 3, 8u);
}

double SimulationConfig::field_half_width_mm() const noexcept {
  switch (preset) {
    case SamplePreset::anterior_segment:
      return anterior.field_half_width_mm;
    case SamplePreset::mirror:
      return mirror.field_half_width_mm;
    case SamplePreset::retina:
    default:
      return retina.field_half_width_mm;
  }
}

}  // namespace ioct::sim
