#include "effective_config.hpp"

#include <sstream>
#include <string_view>

#include "ioct/common/config_error.hpp"

namespace ioct::rt {
namespace {

// One TOML table, key by key.
class TableWriter {
 public:
  TableWriter(std::ostringstream& out, std::string_view name) : out_(out) {
    out_ << "\n[" << name << "]\n";
  }
  TableWriter& text(std::string_view key, std::string_view value) {
    out_ << key << " = \"";
    for (const char c : value) {
      if (c == '"' || c == '\\') out_ << '\\';
      out_ << c;
    }
    out_ << "\"\n";
    return *this;
  }
  TableWriter& integer(std::string_view key, std::int64_t value) {
    out_ << key << " = " << value << "\n";
    return *this;
  }
  TableWriter& real(std::string_view key, double value) {
    std::string v = format_value(value);
    if (v.find_first_of(".eEn") == std::string::npos) v += ".0";  // a float in TOML
    out_ << key << " = " << v << "\n";
    return *this;
  }
  TableWriter& boolean(std::string_view key, bool value) {
    out_ << key << " = " << (value ? "true" : "false") << "\n";
    return *this;
  }
  TableWriter& wiring(std::string_view key, const hal::LineWiring& w) {
    out_ << key << " = { offset = " << w.offset
         << ", active_low = " << (w.active_low ? "true" : "false") << " }\n";
    return *this;
  }

 private:
  std::ostringstream& out_;
};

}  // namespace

std::string effective_config_toml(const RtConfig& c) {
  std::ostringstream out;
  out << "# effective configuration (file, then flags, then defaults)\n";
  TableWriter(out, "ring")
      .text("name", c.ring_name)
      .integer("slots", static_cast<std::int64_t>(c.ring_slots))
      .text("group", c.ring_group);
  TableWriter(out, "digitizer")
      .text("backend", c.digitizer_backend)
      .integer("samples_per_ascan", c.digitizer.samples_per_ascan)
      .integer("ascans_per_bscan", c.digitizer.ascans_per_bscan)
      .integer("flyback_sweeps", c.digitizer.flyback_sweeps)
      .integer("bscans_per_group", c.digitizer.bscans_per_group)
      .real("ascan_rate_hz", c.digitizer.ascan_rate_hz)
      .integer("sample_bits", c.digitizer.sample_bits)
      .text("clock_source", to_string(c.digitizer.clock_source))
      .integer("timeout_ms", c.digitizer.timeout_ms);
  TableWriter(out, "digitizer.trigger")
      .text("source", to_string(c.digitizer.trigger.source))
      .real("level_volts", c.digitizer.trigger.level_volts)
      .integer("delay_samples", c.digitizer.trigger.delay_samples);
  TableWriter(out, "scan")
      .text("pattern", to_string(c.scan.kind))
      .integer("bscans_per_volume", c.bscans_per_volume)
      .integer("repeats", c.scan.repeats)
      .real("extent_x", c.scan.extent_x)
      .real("extent_y", c.scan.extent_y)
      .real("offset_x", c.scan.offset_x)
      .real("offset_y", c.scan.offset_y)
      .real("rotation_deg", c.scan.rotation_deg)
      .integer("inactive_ascans", c.scan.inactive_ascans);
  TableWriter(out, "galvo")
      .text("backend", c.galvo_backend)
      .integer("fifo_capacity", c.galvo.fifo_capacity)
      .real("lead_us", c.galvo_lead_us)
      .real("park_x", c.galvo.park.x)
      .real("park_y", c.galvo.park.y)
      .real("max_velocity", c.galvo_limits.max_velocity)
      .real("max_acceleration", c.galvo_limits.max_acceleration)
      .integer("feed_ahead_groups", c.feed_ahead_groups);
  TableWriter(out, "usb")
      .integer("vendor_id", c.usb_vendor_id)
      .integer("product_id", c.usb_product_id)
      .text("serial", c.usb_serial);
  TableWriter(out, "lines")
      .text("backend", c.lines_backend)
      .text("chip", c.lines.chip)
      .text("consumer", c.lines.consumer)
      .wiring("laser_emission", c.lines.laser_emission)
      .wiring("watchdog", c.lines.watchdog)
      .wiring("laser_ready", c.lines.laser_ready)
      .wiring("sweep_trigger_present", c.lines.sweep_trigger_present)
      .wiring("k_clock_valid", c.lines.k_clock_valid)
      .wiring("footswitch", c.lines.footswitch);
  TableWriter(out, "realtime")
      .integer("priority", c.rt_priority)
      .integer("cpu", c.rt_cpu)
      .boolean("lock_memory", c.lock_memory)
      .integer("safety_priority", c.safety_priority)
      .integer("safety_cpu", c.safety_cpu)
      .integer("check_interval_us", static_cast<std::int64_t>(c.check_interval_us))
      .integer("publish_slack_us", static_cast<std::int64_t>(c.publish_slack_us))
      .integer("max_consecutive_deadline_misses", c.max_consecutive_deadline_misses)
      .integer("stack_prefault_kib", static_cast<std::int64_t>(c.stack_prefault_kib));
  TableWriter(out, "safety")
      .integer("poll_interval_us", static_cast<std::int64_t>(c.poll_interval_us))
      .integer("watchdog_toggle_ms", static_cast<std::int64_t>(c.watchdog_toggle_ms))
      .integer("arming_timeout_ms", static_cast<std::int64_t>(c.arming_timeout_ms))
      .integer("readback_timeout_ms", static_cast<std::int64_t>(c.readback_timeout_ms))
      .integer("stall_timeout_ms", static_cast<std::int64_t>(c.stall_timeout_ms))
      .integer("park_wait_ms", static_cast<std::int64_t>(c.park_wait_ms))
      .integer("max_missed_sweeps_per_group", c.max_missed_sweeps_per_group)
      .boolean("monitor_laser_ready", c.monitor_laser_ready)
      .boolean("monitor_k_clock", c.monitor_k_clock)
      .boolean("monitor_sweep_trigger", c.monitor_sweep_trigger)
      .boolean("require_footswitch", c.require_footswitch)
      .integer("auto_rearm_ms", static_cast<std::int64_t>(c.auto_rearm_ms));
  TableWriter(out, "control")
      .text("socket", c.control_socket)
      .text("socket_group", c.control_group)
      .boolean("start_scanning", c.start_scanning)
      .integer("max_clients", c.max_clients)
      .integer("idle_timeout_ms", static_cast<std::int64_t>(c.idle_timeout_ms));
  TableWriter(out, "status").real("interval_s", c.status_interval_s);
  TableWriter(out, "simulation")
      .integer("seed", static_cast<std::int64_t>(c.simulation_seed))
      .real("mirror_natural_hz", c.mirror_natural_hz)
      .real("mirror_damping", c.mirror_damping)
      .integer("laser_watchdog_timeout_ms", c.laser_watchdog_timeout_ms);
  if (c.simulation_workers < 0) {
    out << "workers = \"auto\"  # " << c.resolved_simulation_workers() << " on this host\n";
  } else {
    out << "workers = " << c.simulation_workers << "\n";
  }
  return out.str();
}

}  // namespace ioct::rt
