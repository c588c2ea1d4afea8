// Everything the simulated acquisition needs besides the digitizer geometry: the source, the
// detector, the eye and where the scanner points the beam.
#pragma once

#include <cstdint>

#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/detector.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/swept_source.hpp"

namespace ioct::sim {

struct SimulationConfig {
  SweptSourceConfig source;
  DetectorConfig detector;
  RetinaConfig retina;
  hal::RasterScan scan;    // the galvo pattern the beam follows, sweep by sweep
  std::uint64_t seed = 1;  // same seed, config and build: same bytes

  // Throws ioct::ConfigError naming the key ("source.", "detector.", "retina.", "scan.").
  void validate() const;
};

}  // namespace ioct::sim
