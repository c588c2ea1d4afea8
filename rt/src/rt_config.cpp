#include "rt_config.hpp"

#include <sys/un.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <set>
#include <sstream>
#include <string_view>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/shm/shm_object.hpp"
#include "rt_keys.hpp"

namespace ioct::rt {

std::uint32_t RtConfig::galvo_lead_samples() const noexcept {
  const double sweeps = galvo_lead_us * 1e-6 * digitizer.ascan_rate_hz;
  return sweeps <= 0.0 ? 0u : static_cast<std::uint32_t>(std::llround(sweeps));
}

int RtConfig::effective_safety_priority() const noexcept {
  if (safety_priority >= 0) return safety_priority;
  return rt_priority == 0 ? 0 : std::min(99, rt_priority + 5);
}

std::uint64_t RtConfig::effective_stall_timeout_ms() const noexcept {
  if (stall_timeout_ms != 0) return stall_timeout_ms;
  const double group_ms =
      static_cast<double>(digitizer.sweeps_per_group()) * digitizer.sweep_period_ns() * 1e-6;
  return static_cast<std::uint64_t>(group_ms) + digitizer.timeout_ms + 100;
}

void RtConfig::validate() const {
  rt_keys().check_ranges(*this);
  if (ring_name.empty()) throw ConfigError("ring.name", "\"\"", "must name the ring");
  // The ring's own check, under its key: so a bad name is placed in the file and its flag named.
  if (const std::string problem = shm::object_name_problem(ring_name); !problem.empty()) {
    throw ConfigError("ring.name", format_text(ring_name), problem);
  }
  digitizer.validate();
  scan.validate();
  hal::GalvoOutputConfig g = galvo;
  g.sample_rate_hz = digitizer.ascan_rate_hz;
  g.validate();
  if (galvo_lead_samples() > galvo.fifo_capacity / 2) {
    throw ConfigError("galvo.lead_us", format_value(galvo_lead_us),
                      "is " + format_value(std::uint64_t{galvo_lead_samples()}) +
                          " sweeps at this rate; at most galvo.fifo_capacity / 2 = " +
                          format_value(std::uint64_t{galvo.fifo_capacity / 2}));
  }
  galvo_limits.validate();
  if (galvo.fifo_capacity <= digitizer.sweeps_per_group()) {
    throw ConfigError("galvo.fifo_capacity", format_value(std::uint64_t{galvo.fifo_capacity}),
                      "must hold more than one group of sweeps (" +
                          format_value(digitizer.sweeps_per_group()) +
                          ") so the DAC is always fed ahead of the beam");
  }
  if (galvo_backend == "usb" && digitizer_backend != "usb") {
    throw ConfigError("galvo.backend", "\"usb\"",
                      "needs digitizer.backend = \"usb\": the galvo DAC streams through the same "
                      "instrument");
  }
  lines.validate();
  if (rt_priority > 0 && safety_priority > 0 && safety_priority <= rt_priority) {
    throw ConfigError(
        "realtime.safety_priority", format_value(std::int64_t{safety_priority}),
        "must be above realtime.priority = " + format_value(std::int64_t{rt_priority}) +
            ": the safety thread preempts the acquisition thread");
  }
  if (stall_timeout_ms != 0) {
    require_integer_in_range("safety.stall_timeout_ms", stall_timeout_ms, 10, 600'000);
  }
  if (control_socket.size() >= sizeof(sockaddr_un{}.sun_path)) {
    throw ConfigError("control.socket", format_text(control_socket),
                      "must be shorter than " + std::to_string(sizeof(sockaddr_un{}.sun_path)) +
                          " bytes (a Unix socket path)");
  }
  // The count here, for the file and --sim-instrument alike; each spec is parsed where the
  // simulator is set up (rt_options.cpp), the only part that links it.
  if (simulation_instruments.size() > kMaxSimulationInstruments) {
    throw ConfigError(
        "simulation.instruments",
        format_value(std::uint64_t{simulation_instruments.size()}) + " items",
        "must have at most " + format_value(std::uint64_t{kMaxSimulationInstruments}));
  }
}

namespace {

bool drives_hardware(const RtConfig& c) {
  return c.digitizer_backend != "simulated" || c.galvo_backend != "simulated" ||
         c.lines_backend != "simulated";
}

// With real hardware a missing key must not fall back to a default: a half-copied file would
// otherwise start scanning with no control socket and the default limits.
void require_safety_keys(const RtConfig& c, const std::string& origin, const KeyPositions& present,
                         SourcePosition end) {
  if (!drives_hardware(c)) return;
  std::string missing;
  for (const char* key : kSafetyKeysOnHardware) {
    if (!present.contains(key)) missing += (missing.empty() ? "" : ", ") + std::string(key);
  }
  if (c.lines_backend != "simulated") {
    for (const char* key : {"lines.laser_emission.offset", "lines.watchdog.offset"}) {
      if (!present.contains(key)) missing += (missing.empty() ? "" : ", ") + std::string(key);
    }
  }
  if (missing.empty()) return;
  const std::string backend =
      c.digitizer_backend != "simulated" ? "digitizer.backend = " + format_text(c.digitizer_backend)
      : c.galvo_backend != "simulated"   ? "galvo.backend = " + format_text(c.galvo_backend)
                                         : "lines.backend = " + format_text(c.lines_backend);
  throw ConfigFileError(origin, end,
                        "with real hardware (" + backend +
                            ") every safety-relevant key must be set in the file, and these are "
                            "not (is the file complete?): " +
                            missing);
}

}  // namespace

const std::vector<const char*> kSafetyKeysOnHardware = {
    "control.socket",
    "control.socket_group",
    "control.start_scanning",
    "control.max_clients",
    "galvo.max_velocity",
    "galvo.max_acceleration",
    "galvo.park_x",
    "galvo.park_y",
    "safety.arming_timeout_ms",
    "safety.readback_timeout_ms",
    "safety.stall_timeout_ms",
    "safety.park_wait_ms",
    "safety.monitor_laser_ready",
    "safety.monitor_k_clock",
    "safety.monitor_sweep_trigger",
    "safety.require_footswitch",
    "safety.auto_rearm_ms",
    "safety.max_missed_sweeps_per_group",
};

void load_config_text(const std::string& text, const std::string& origin, RtConfig& config,
                      KeyPositions* positions) {
  KeyPositions present;
  rt_keys().read_text(text, origin, config, &present);
  const SourcePosition end{
      static_cast<std::uint32_t>(std::count(text.begin(), text.end(), '\n') + 1), 1};
  require_safety_keys(config, origin, present, end);
  if (positions != nullptr) positions->insert(present.begin(), present.end());
}

void load_config_file(const std::string& path, RtConfig& config, KeyPositions* positions) {
  load_config_text(config::read_config_file(path), path, config, positions);
}

}  // namespace ioct::rt
