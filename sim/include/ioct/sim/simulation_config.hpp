// Everything the simulated acquisition needs besides the digitizer geometry: the source, the
// interferometer, the detector, the sample (one of the presets) and its instruments, the bench,
// and where the scanner points the beam.
#pragma once

#include <cstdint>
#include <vector>

#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/anterior_segment_model.hpp"
#include "ioct/sim/detector.hpp"
#include "ioct/sim/instrument_model.hpp"
#include "ioct/sim/interferometer.hpp"
#include "ioct/sim/mirror_model.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/sample_model.hpp"
#include "ioct/sim/simulated_bench.hpp"
#include "ioct/sim/swept_source.hpp"

namespace ioct::sim {

struct SimulationConfig {
  static constexpr std::size_t kMaxInstruments = 4;

  SweptSourceConfig source;
  InterferometerConfig interferometer;
  DetectorConfig detector;
  SamplePreset preset = SamplePreset::retina;
  RetinaConfig retina;             // preset retina
  AnteriorSegmentConfig anterior;  // preset anterior_segment
  MirrorConfig mirror;             // preset mirror
  std::vector<InstrumentConfig> instruments;
  // Size of the tissue cells that carry independent speckle, um on the sample.
  double speckle_grain_um = 8.0;
  BenchConfig bench;       // used when the digitizer makes its own bench
  hal::RasterScan scan;    // the galvo pattern the beam follows when no galvo output drives it
  std::uint64_t seed = 1;  // same seed, config and build: same bytes
  // Threads that synthesise groups ahead of acquire_group(), B-scan by B-scan (same bytes for
  // any count). 0: each group is synthesised inside acquire_group() on the caller's thread.
  std::uint32_t workers = 0;
  static constexpr std::uint32_t kMaxWorkers = 64;
  // SCHED_FIFO priority of the workers (1-99; 0: normal scheduling). A simulator stands in for
  // hardware, which nothing else on the host slows down: under a real-time acquisition thread
  // the workers run real-time too, below it. Where the host refuses, they run normally
  // (SimulatedDigitizer::realtime_workers() says how many got it).
  int worker_priority = 0;

  // A worker count for a host with `hardware_threads` (0: unknown) that leaves cores to the
  // acquisition thread and the GPU process: hardware_threads - 3, at least 1, at most 8.
  static std::uint32_t default_workers(unsigned hardware_threads) noexcept;

  // Throws ioct::ConfigError naming the key ("source.", "interferometer.", "detector.",
  // "retina.", "anterior.", "mirror.", "instruments[i].", "bench.", "scan.", "simulation.").
  void validate() const;
  // The preset's lateral field: scan units +-1 span +-field_half_width_mm() on the sample.
  double field_half_width_mm() const noexcept;
};

}  // namespace ioct::sim
