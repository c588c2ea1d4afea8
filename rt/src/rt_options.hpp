// ioct-rt's command line and the validated configs it turns into.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "ioct/hal/digitizer_config.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/sim/simulation_config.hpp"
#include "realtime_setup.hpp"

namespace ioct::rt {

struct RtOptions {
  std::string ring = "ioct-ring";
  std::uint64_t slots = 8;
  std::uint32_t samples = 1376;
  std::uint32_t ascans = 512;
  std::uint32_t flyback = 26;
  std::uint32_t bscans_per_group = 16;
  std::uint32_t bscans_per_volume = 128;
  double ascan_rate = 100'000.0;
  double seconds = 0.0;  // 0: until SIGINT or SIGTERM
  std::string group;     // group owning the ring; empty: the process's
  std::uint64_t seed = 1;
  double status_interval = 1.0;
  int rt_priority = 80;
  int cpu = -1;
  std::string summary;  // JSON file written at exit; empty: none
};

void add_rt_options(CLI::App& app, RtOptions& options);

struct RtSetup {
  shm::RingConfig ring;
  hal::DigitizerConfig digitizer;
  sim::SimulationConfig simulation;
  RealtimeRequest realtime;
};

// Builds and validates every config. Throws ioct::ConfigError or shm::RingError(bad_config)
// naming the config key; option_for_error() tells which option sets it.
RtSetup make_setup(const RtOptions& options);

// The command-line option behind the config key that a validation error's message names
// ("--samples" for "digitizer.samples_per_ascan = 7: ..."), or empty when none does.
std::string option_for_error(const std::string& message);

}  // namespace ioct::rt
