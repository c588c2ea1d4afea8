// ioct-rt's command line and the validated configs it turns into. A configuration file
// (--config) gives every key; a flag given on the command line overrides its key.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ioct/hal/digitizer_config.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/sim/simulation_config.hpp"
#include "realtime_setup.hpp"
#include "rt_config.hpp"

namespace ioct::rt {

struct RtOptions {
  std::string config;  // TOML file; empty: the built-in defaults
  std::string ring = "ioct-ring";
  std::uint64_t slots = 8;
  std::uint32_t samples = 1376;
  std::uint32_t ascans = 512;
  std::uint32_t flyback = 26;
  std::uint32_t bscans_per_group = 16;
  std::uint32_t bscans_per_volume = 128;
  double ascan_rate = 100'000.0;
  std::string group;  // group owning the ring; empty: the process's
  std::uint64_t seed = 1;
  double status_interval = 1.0;
  int rt_priority = 80;
  int cpu = -1;
  std::string pattern = "raster";
  std::string control_socket;                // empty: none
  std::vector<std::string> sim_instruments;  // simulation.instruments
  // Run-time only (not configuration keys).
  std::string replay;         // play this recording (HDF5 ring or raw) instead of acquiring
  bool replay_once = false;   // stop at the recording's end instead of starting it again
  double replay_speed = 1.0;  // the replay's group rate over the recorded one (> 0)
  double seconds = 0.0;       // 0: until SIGINT or SIGTERM
  std::string summary;        // JSON file written at exit; empty: none
  bool check_config = false;
  bool self_test = false;
  double self_test_seconds = 10.0;
  std::uint64_t self_test_interval_us = 1000;
  std::uint64_t self_test_threshold_us = 100;
  // The long option names given on the command line. nullopt (a program filling the struct):
  // every field counts, as if all were given.
  std::optional<std::set<std::string>> given;
};

void add_rt_options(CLI::App& app, RtOptions& options);
// Records in options.given which of the overriding options the command line had.
void note_given_options(const CLI::App& app, RtOptions& options);

struct RtSetup {
  RtConfig config;
  shm::RingConfig ring;
  hal::DigitizerConfig digitizer;
  sim::SimulationConfig simulation;
  RealtimeRequest realtime;
  std::string replay_file;  // empty: acquire (the configured digitizer backend)
  bool replay_loop = true;
  double replay_speed = 1.0;  // 1: as recorded; 8: eight times as many groups per second
};

// Reads the file (if any), applies the given flags, validates everything and derives each part's
// config. Throws ConfigFileError ("file:line:col: key = value: allowed") for what the file got
// wrong, ioct::ConfigError or shm::RingError(bad_config) naming the key otherwise (see
// option_for_error()), ScanInfeasible for a pattern the galvo cannot follow.
RtSetup make_setup(const RtOptions& options);

// The command-line option behind the config key that a validation error's message names
// ("--samples" for "digitizer.samples_per_ascan = 7: ..."), or empty when none does.
std::string option_for_error(const std::string& message);

}  // namespace ioct::rt
