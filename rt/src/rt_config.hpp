// Everything ioct-rt is configured with, as one validated struct: read from a TOML file, then
// overridden by command-line flags; each key is declared once, in rt_keys.cpp
// (docs/config-keys.md). Unknown keys are refused; every error names the key, the value, what is
// allowed and, for a file, file:line.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ioct/config/config_file_error.hpp"
#include "ioct/hal/digitizer_config.hpp"
#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/lines.hpp"
#include "ioct/scan/scan_spec.hpp"

namespace ioct::rt {

struct RtConfig {
  // [ring]
  std::string ring_name = "ioct-ring";
  std::uint64_t ring_slots = 8;
  std::string ring_group;  // owner group of the ring; empty: the process's

  // [digitizer]
  std::string digitizer_backend = "simulated";
  hal::DigitizerConfig digitizer;

  // [scan]
  std::uint32_t bscans_per_volume = 128;
  scan::ScanSpec scan;

  // [galvo]
  std::string galvo_backend = "simulated";
  // sample_rate_hz follows digitizer.ascan_rate_hz; lead_samples is derived from galvo_lead_us.
  hal::GalvoOutputConfig galvo;
  // Galvo lead compensation, as a time: the mirrors' lag behind their command. 111.4 us is
  // 2 zeta / omega of the simulator's default mirrors (2 kHz, zeta 0.7); measure the real
  // scanner's on the bench.
  double galvo_lead_us = 111.4;
  scan::GalvoLimits galvo_limits;
  std::uint32_t feed_ahead_groups = 3;

  // [usb]: the USB instrument (digitizer and galvo DAC) when a backend is "usb".
  std::uint32_t usb_vendor_id = 0x1209;  // placeholder IDs, as hal/usb's and the udev rules'
  std::uint32_t usb_product_id = 0x0001;
  std::string usb_serial;  // empty: the first instrument with these IDs

  // [lines]
  std::string lines_backend = "simulated";
  hal::LinesConfig lines;

  // [realtime]
  int rt_priority = 80;  // SCHED_FIFO of the acquisition thread; 0: none
  int rt_cpu = -1;       // CPU to pin it to; -1: none
  bool lock_memory = true;
  int safety_priority = -1;  // of the safety thread; -1: rt_priority + 5 (max 99), 0: none
  int safety_cpu = -1;
  std::uint64_t check_interval_us = 1000;
  std::uint64_t publish_slack_us = 2000;
  std::uint32_t max_consecutive_deadline_misses = 3;
  std::uint64_t stack_prefault_kib = 256;

  // [safety]
  std::uint64_t poll_interval_us = 1000;
  std::uint64_t watchdog_toggle_ms = 5;
  std::uint64_t arming_timeout_ms = 2000;
  std::uint64_t readback_timeout_ms = 10;
  std::uint64_t stall_timeout_ms = 0;  // 0: one group + digitizer.timeout_ms + 100 ms
  std::uint64_t park_wait_ms = 20;
  std::uint32_t max_missed_sweeps_per_group = 8;
  bool monitor_laser_ready = true;
  bool monitor_k_clock = true;
  bool monitor_sweep_trigger = true;
  bool require_footswitch = false;
  std::uint64_t auto_rearm_ms = 0;  // 0: re-arm on a start command only

  // [control]
  std::string control_socket;  // empty: no control channel
  std::string control_group;   // group of the socket (mode 0660); empty: the process's
  // Arm at start-up without waiting for a start command. With real hardware the file must set it
  // (kSafetyKeysOnHardware); the simulator starts at once.
  bool start_scanning = true;
  std::uint32_t max_clients = 8;
  // A client that sends no request for this long is closed (idle clients cannot hold slots).
  std::uint64_t idle_timeout_ms = 30'000;

  // [status]
  double status_interval_s = 1.0;

  // [simulation]
  std::uint64_t simulation_seed = 1;
  double mirror_natural_hz = 2000.0;  // the simulated galvo servo's bandwidth
  double mirror_damping = 0.7;
  std::uint32_t laser_watchdog_timeout_ms = 100;  // the simulated external laser watchdog
  // Threads synthesising the simulated digitizer's groups ahead; -1: "auto"
  // (sim::SimulationConfig::default_workers of this host), 0: on the acquisition thread.
  std::int64_t simulation_workers = -1;
  // Instruments in the simulated scene, one line each (sim/instrument_spec.hpp), e.g.
  // "forceps:x=0.1,depth=0.35,tremor-depth=0.08,tremor-hz=0.1".
  std::vector<std::string> simulation_instruments;
  static constexpr std::size_t kMaxSimulationInstruments = 4;
  static constexpr std::int64_t kMaxSimulationWorkers = 64;  // sim::SimulationConfig::kMaxWorkers
  // The worker count this host runs with (defined with the simulator's setup, rt_options.cpp).
  std::uint32_t resolved_simulation_workers() const noexcept;

  // Every key's range (rt_keys()), the cross-checks and each part's own validate(); throws
  // ConfigError naming the key.
  void validate() const;

  int effective_safety_priority() const noexcept;
  // galvo_lead_us in sweeps at the A-scan rate, rounded.
  std::uint32_t galvo_lead_samples() const noexcept;
  std::uint64_t effective_stall_timeout_ms() const noexcept;
};

// The file's errors and where its keys were: the configuration library's (config/).
using config::ConfigFileError;
using config::KeyPositions;
using config::kMaxConfigBytes;
using config::SourcePosition;

// The keys a file must set itself when any backend is real hardware (docs/operations.md).
extern const std::vector<const char*> kSafetyKeysOnHardware;

// Reads `path` over `config` (keys absent from the file keep their value). Throws
// ConfigFileError for a syntax error, an unknown key, a value of the wrong type or out of range;
// the file's keys and where they are go to `positions` when given. Refused as well: a path that
// is not a regular file or is larger than kMaxConfigBytes (ioct::InputFileError), an empty file
// (no key), a file that does not end with a newline (cut off), and, with a real backend, a file
// that leaves out any of kSafetyKeysOnHardware.
void load_config_file(const std::string& path, RtConfig& config, KeyPositions* positions = nullptr);

// Reads TOML text (`origin` names it in errors); what load_config_file() does after reading.
void load_config_text(const std::string& text, const std::string& origin, RtConfig& config,
                      KeyPositions* positions = nullptr);

}  // namespace ioct::rt
