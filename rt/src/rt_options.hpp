// ioct-rt's command line and the validated configs it turns into. A configuration file
// (--config) gives every key; a flag given on the command line overrides its key.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "ioct/config/key_spec.hpp"
#include "ioct/hal/digitizer_config.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/sim/simulation_config.hpp"
#include "realtime_setup.hpp"
#include "rt_config.hpp"

namespace ioct::rt {

struct RtOptions {
  std::string config;  // TOML file; empty: the built-in defaults
  // Configuration keys set by flags (rt_keys(): --slots sets ring.slots), over the file's.
  config::Overrides overrides;
  // Run-time only (not configuration keys).
  std::string replay;         // play this recording (HDF5 ring or raw) instead of acquiring
  bool replay_once = false;   // stop at the recording's end instead of starting it again
  double replay_speed = 1.0;  // the replay's group rate over the recorded one (> 0)
  double seconds = 0.0;       // 0: until SIGINT or SIGTERM
  std::string summary;        // JSON file written at exit; empty: none
  bool check_config = false;
  bool config_keys = false;  // print every key as docs/config-keys.md shows it, exit
  bool self_test = false;
  double self_test_seconds = 10.0;
  std::uint64_t self_test_interval_us = 1000;
  std::uint64_t self_test_threshold_us = 100;

  // Sets a configuration key as its flag would ("ring.slots", "4").
  RtOptions& set(const std::string& key, std::string value) {
    overrides[key] = {std::move(value)};
    return *this;
  }
};

// The run-time options and a flag for each configuration key that has one (rt_keys()).
void add_rt_options(CLI::App& app, RtOptions& options);

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
// wrong, ioct::ConfigError naming the key otherwise (see option_for_key()), shm::RingError
// (bad_config) for a ring the shm layer refuses, scan::ScanInfeasible for a pattern the galvo
// cannot follow.
RtSetup make_setup(const RtOptions& options);

// The command-line option that sets the key a ConfigError names ("--samples" for
// "digitizer.samples_per_ascan"), or empty when none does.
std::string option_for_key(const std::string& key);

}  // namespace ioct::rt
