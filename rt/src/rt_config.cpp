#include "rt_config.hpp"

#include <sys/un.h>

#include <toml++/toml.h>
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
#include "ioct/common/input_file.hpp"

namespace ioct::rt {
namespace {

// A string of the file as a message shows it: printable, shortened (quote_input).
std::string quoted(std::string_view text) {
  return "\"" + quote_input(text, 60) + "\"";
}

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a number";
    case toml::node_type::boolean:
      return "a boolean";
    default:
      return "a date or time";
  }
}

std::string shown_value(const toml::node& node) {
  std::ostringstream out;
  if (const auto* s = node.as_string()) return quoted(s->get());
  node.visit([&](const auto& n) { out << n; });
  return out.str();
}

SourcePosition position_of(const toml::source_region& source) {
  return {static_cast<std::uint32_t>(source.begin.line),
          static_cast<std::uint32_t>(source.begin.column)};
}

// One table of the file: reads its known keys into the config, refuses the rest.
class Section {
 public:
  Section(const toml::table* table, std::string prefix, const std::string& origin,
          KeyPositions* positions)
      : table_(table), prefix_(std::move(prefix)), origin_(origin), positions_(positions) {}

  template <typename T>
  void integer(std::string_view key, T& out, std::int64_t lo, std::int64_t hi) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    const auto* value = node->as_integer();
    if (value == nullptr) wrong_type(key, *node, "an integer");
    const std::int64_t v = value->get();
    if (v < lo || v > hi) {
      fail(key, *node,
           ConfigError(full(key), format_value(v),
                       "must be in [" + format_value(lo) + ", " + format_value(hi) + "]")
               .what());
    }
    out = static_cast<T>(v);
  }

  // An integer in [lo, hi], or the text "auto" (stored as -1).
  void integer_or_auto(std::string_view key, std::int64_t& out, std::int64_t lo, std::int64_t hi) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    if (const auto* text = node->as_string()) {
      if (text->get() != "auto") {
        fail(key, *node,
             ConfigError(full(key), quoted(text->get()),
                         "must be \"auto\" or an integer in [" + format_value(lo) + ", " +
                             format_value(hi) + "]")
                 .what());
      }
      out = -1;
      return;
    }
    integer(key, out, lo, hi);
  }

  void real(std::string_view key, double& out) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    if (const auto* f = node->as_floating_point()) {
      out = f->get();
    } else if (const auto* i = node->as_integer()) {
      out = static_cast<double>(i->get());
    } else {
      wrong_type(key, *node, "a number");
    }
  }

  void real(std::string_view key, float& out) {
    double v = out;
    real(key, v);
    out = static_cast<float>(v);
  }

  void boolean(std::string_view key, bool& out) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    const auto* value = node->as_boolean();
    if (value == nullptr) wrong_type(key, *node, "true or false");
    out = value->get();
  }

  // An array of strings.
  void text_list(std::string_view key, std::vector<std::string>& out) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    const auto* array = node->as_array();
    if (array == nullptr) wrong_type(key, *node, "an array of strings");
    std::vector<std::string> items;
    for (const toml::node& item : *array) {
      const auto* value = item.as_string();
      if (value == nullptr) wrong_type(key, item, "an array of strings");
      items.push_back(value->get());
    }
    out = std::move(items);
  }

  void text(std::string_view key, std::string& out) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    const auto* value = node->as_string();
    if (value == nullptr) wrong_type(key, *node, "a string");
    out = value->get();
  }

  // A string that must be one of `allowed`.
  void choice(std::string_view key, std::string& out,
              std::initializer_list<std::string_view> allowed) {
    const toml::node* node = find(key);
    if (node == nullptr) return;
    const auto* value = node->as_string();
    if (value == nullptr) wrong_type(key, *node, "a string");
    const std::string& v = value->get();
    if (std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
      std::string list;
      for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      fail(key, *node, ConfigError(full(key), quoted(v), "must be one of " + list).what());
    }
    out = v;
  }

  // A nested table; absent gives an empty section.
  Section table(std::string_view key) {
    const toml::node* node = find(key);
    if (node == nullptr) return Section(nullptr, full(key), origin_, positions_);
    const auto* t = node->as_table();
    if (t == nullptr) wrong_type(key, *node, "a table");
    return Section(t, full(key), origin_, positions_);
  }

  // Refuses every key that was not asked for, naming the ones this table takes.
  void done() const {
    if (table_ == nullptr) return;
    for (auto&& [key, node] : *table_) {
      if (read_.count(std::string(key.str())) != 0) continue;
      std::string list;
      for (const std::string& k : known_) list += (list.empty() ? "" : ", ") + k;
      // A quoted TOML key may hold any character: shown printable.
      const std::string name = quote_input(full(key.str()), 80);
      throw ConfigFileError(origin_, position_of(key.source()),
                            name + ": unknown key; " +
                                (prefix_.empty() ? std::string("the file") : "[" + prefix_ + "]") +
                                " takes " + list);
    }
  }

 private:
  const toml::node* find(std::string_view key) {
    known_.emplace_back(key);
    read_.emplace(key);
    if (table_ == nullptr) return nullptr;
    const toml::node* node = table_->get(key);
    if (node != nullptr && positions_ != nullptr) {
      (*positions_)[full(key)] = position_of(node->source());
    }
    return node;
  }

  std::string full(std::string_view key) const {
    return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key);
  }

  [[noreturn]] void wrong_type(std::string_view key, const toml::node& node,
                               const char* wanted) const {
    fail(key, node,
         ConfigError(full(key), shown_value(node),
                     std::string("must be ") + wanted + ", not " + type_name(node))
             .what());
  }

  [[noreturn]] void fail(std::string_view, const toml::node& node,
                         const std::string& message) const {
    throw ConfigFileError(origin_, position_of(node.source()), message);
  }

  const toml::table* table_;
  std::string prefix_;
  const std::string& origin_;
  KeyPositions* positions_;
  std::vector<std::string> known_;
  std::set<std::string> read_;
};

constexpr std::int64_t kU32 = std::numeric_limits<std::uint32_t>::max();

void read_wiring(Section& lines, std::string_view name, hal::LineWiring& wiring) {
  Section line = lines.table(name);
  line.integer("offset", wiring.offset, 0, 1023);
  line.boolean("active_low", wiring.active_low);
  line.done();
}

void read_tables(const toml::table& root, const std::string& origin, RtConfig& c,
                 KeyPositions* positions) {
  Section top(&root, "", origin, positions);

  Section ring = top.table("ring");
  ring.text("name", c.ring_name);
  ring.integer("slots", c.ring_slots, 2, 4096);
  ring.text("group", c.ring_group);
  ring.done();

  Section dig = top.table("digitizer");
  dig.choice("backend", c.digitizer_backend, {"simulated", "usb"});
  dig.integer("samples_per_ascan", c.digitizer.samples_per_ascan, 16, 16384);
  dig.integer("ascans_per_bscan", c.digitizer.ascans_per_bscan, 1, 65536);
  dig.integer("flyback_sweeps", c.digitizer.flyback_sweeps, 0, 65536);
  dig.integer("bscans_per_group", c.digitizer.bscans_per_group, 1, 1024);
  dig.real("ascan_rate_hz", c.digitizer.ascan_rate_hz);
  dig.integer("sample_bits", c.digitizer.sample_bits, 8, 16);
  std::string clock(to_string(c.digitizer.clock_source));
  dig.choice("clock_source", clock, {"external_k_clock", "internal"});
  c.digitizer.clock_source =
      clock == "internal" ? hal::ClockSource::internal : hal::ClockSource::external_k_clock;
  dig.integer("timeout_ms", c.digitizer.timeout_ms, 1, 60'000);
  Section trigger = dig.table("trigger");
  std::string source(to_string(c.digitizer.trigger.source));
  trigger.choice("source", source, {"sweep_input", "software"});
  c.digitizer.trigger.source =
      source == "software" ? hal::TriggerSource::software : hal::TriggerSource::sweep_input;
  trigger.real("level_volts", c.digitizer.trigger.level_volts);
  trigger.integer("delay_samples", c.digitizer.trigger.delay_samples, 0, 65536);
  trigger.done();
  dig.done();

  Section scan = top.table("scan");
  std::string pattern(to_string(c.scan.kind));
  scan.choice("pattern", pattern, {"raster", "bidirectional", "crosshair", "radial"});
  c.scan.kind = *scan_kind_from_string(pattern);
  scan.integer("bscans_per_volume", c.bscans_per_volume, 1, 65536);
  scan.integer("repeats", c.scan.repeats, 1, 65536);
  scan.real("extent_x", c.scan.extent_x);
  scan.real("extent_y", c.scan.extent_y);
  scan.real("offset_x", c.scan.offset_x);
  scan.real("offset_y", c.scan.offset_y);
  scan.real("rotation_deg", c.scan.rotation_deg);
  scan.integer("inactive_ascans", c.scan.inactive_ascans, 0, 32767);
  scan.done();

  Section galvo = top.table("galvo");
  galvo.choice("backend", c.galvo_backend, {"simulated", "usb"});
  galvo.integer("fifo_capacity", c.galvo.fifo_capacity, 16, 1 << 24);
  galvo.real("lead_us", c.galvo_lead_us);
  galvo.real("park_x", c.galvo.park.x);
  galvo.real("park_y", c.galvo.park.y);
  galvo.real("max_velocity", c.galvo_limits.max_velocity);
  galvo.real("max_acceleration", c.galvo_limits.max_acceleration);
  galvo.integer("feed_ahead_groups", c.feed_ahead_groups, 1, 64);
  galvo.done();

  Section usb = top.table("usb");
  usb.integer("vendor_id", c.usb_vendor_id, 1, 0xFFFF);
  usb.integer("product_id", c.usb_product_id, 0, 0xFFFF);
  usb.text("serial", c.usb_serial);
  usb.done();

  Section lines = top.table("lines");
  lines.choice("backend", c.lines_backend, {"simulated", "gpio"});
  lines.text("chip", c.lines.chip);
  lines.text("consumer", c.lines.consumer);
  read_wiring(lines, "laser_emission", c.lines.laser_emission);
  read_wiring(lines, "watchdog", c.lines.watchdog);
  read_wiring(lines, "laser_ready", c.lines.laser_ready);
  read_wiring(lines, "sweep_trigger_present", c.lines.sweep_trigger_present);
  read_wiring(lines, "k_clock_valid", c.lines.k_clock_valid);
  read_wiring(lines, "footswitch", c.lines.footswitch);
  lines.done();

  Section rt = top.table("realtime");
  rt.integer("priority", c.rt_priority, 0, 99);
  rt.integer("cpu", c.rt_cpu, -1, 1023);
  rt.boolean("lock_memory", c.lock_memory);
  rt.integer("safety_priority", c.safety_priority, -1, 99);
  rt.integer("safety_cpu", c.safety_cpu, -1, 1023);
  rt.integer("check_interval_us", c.check_interval_us, 50, 100'000);
  rt.integer("publish_slack_us", c.publish_slack_us, 0, 10'000'000);
  rt.integer("max_consecutive_deadline_misses", c.max_consecutive_deadline_misses, 0, 1000);
  rt.integer("stack_prefault_kib", c.stack_prefault_kib, 16, 65536);
  rt.done();

  Section safety = top.table("safety");
  safety.integer("poll_interval_us", c.poll_interval_us, 100, 100'000);
  safety.integer("watchdog_toggle_ms", c.watchdog_toggle_ms, 1, 10'000);
  safety.integer("arming_timeout_ms", c.arming_timeout_ms, 10, 60'000);
  safety.integer("readback_timeout_ms", c.readback_timeout_ms, 1, 10'000);
  safety.integer("stall_timeout_ms", c.stall_timeout_ms, 0, 600'000);
  safety.integer("park_wait_ms", c.park_wait_ms, 1, 10'000);
  safety.integer("max_missed_sweeps_per_group", c.max_missed_sweeps_per_group, 0, kU32);
  safety.boolean("monitor_laser_ready", c.monitor_laser_ready);
  safety.boolean("monitor_k_clock", c.monitor_k_clock);
  safety.boolean("monitor_sweep_trigger", c.monitor_sweep_trigger);
  safety.boolean("require_footswitch", c.require_footswitch);
  safety.integer("auto_rearm_ms", c.auto_rearm_ms, 0, 3'600'000);
  safety.done();

  Section control = top.table("control");
  control.text("socket", c.control_socket);
  control.text("socket_group", c.control_group);
  control.boolean("start_scanning", c.start_scanning);
  control.integer("max_clients", c.max_clients, 1, 64);
  control.integer("idle_timeout_ms", c.idle_timeout_ms, 100, 86'400'000);
  control.done();

  Section status = top.table("status");
  status.real("interval_s", c.status_interval_s);
  status.done();

  Section simulation = top.table("simulation");
  simulation.integer("seed", c.simulation_seed, 0, std::numeric_limits<std::int64_t>::max());
  simulation.real("mirror_natural_hz", c.mirror_natural_hz);
  simulation.real("mirror_damping", c.mirror_damping);
  simulation.integer("laser_watchdog_timeout_ms", c.laser_watchdog_timeout_ms, 0, 60'000);
  simulation.integer_or_auto("workers", c.simulation_workers, 0, RtConfig::kMaxSimulationWorkers);
  simulation.text_list("instruments", c.simulation_instruments);
  simulation.done();

  top.done();
}

void require_int(std::string_view key, std::int64_t value, std::int64_t lo, std::int64_t hi) {
  if (value < lo || value > hi) {
    throw ConfigError(std::string(key), format_value(value),
                      "must be in [" + format_value(lo) + ", " + format_value(hi) + "]");
  }
}

void require_one_of(std::string_view key, const std::string& value,
                    std::initializer_list<std::string_view> allowed) {
  if (std::find(allowed.begin(), allowed.end(), value) != allowed.end()) return;
  std::string list;
  for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
  throw ConfigError(std::string(key), quoted(value), "must be one of " + list);
}

}  // namespace

ConfigFileError::ConfigFileError(const std::string& file, SourcePosition position,
                                 const std::string& message)
    : std::runtime_error(file + ":" + std::to_string(position.line) + ":" +
                         std::to_string(position.column) + ": " + message),
      file_(file),
      position_(position) {}

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
  if (ring_name.empty()) throw ConfigError("ring.name", "\"\"", "must name the ring");
  require_integer_in_range("ring.slots", ring_slots, 2, 4096);
  require_one_of("digitizer.backend", digitizer_backend, {"simulated", "usb"});
  digitizer.validate();
  require_integer_in_range("scan.bscans_per_volume", bscans_per_volume, 1, 65536);
  scan.validate();
  require_one_of("galvo.backend", galvo_backend, {"simulated", "usb"});
  require_real_in_range("galvo.lead_us", galvo_lead_us, 0.0, 100'000.0);
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
  require_integer_in_range("galvo.feed_ahead_groups", feed_ahead_groups, 1, 64);
  if (galvo.fifo_capacity <= digitizer.sweeps_per_group()) {
    throw ConfigError("galvo.fifo_capacity", format_value(std::uint64_t{galvo.fifo_capacity}),
                      "must hold more than one group of sweeps (" +
                          format_value(digitizer.sweeps_per_group()) +
                          ") so the DAC is always fed ahead of the beam");
  }
  require_integer_in_range("usb.vendor_id", usb_vendor_id, 1, 0xFFFF);
  require_integer_in_range("usb.product_id", usb_product_id, 0, 0xFFFF);
  if (galvo_backend == "usb" && digitizer_backend != "usb") {
    throw ConfigError("galvo.backend", "\"usb\"",
                      "needs digitizer.backend = \"usb\": the galvo DAC streams through the same "
                      "instrument");
  }
  require_one_of("lines.backend", lines_backend, {"simulated", "gpio"});
  lines.validate();
  require_int("realtime.priority", rt_priority, 0, 99);
  require_int("realtime.cpu", rt_cpu, -1, 1023);
  require_int("realtime.safety_priority", safety_priority, -1, 99);
  require_int("realtime.safety_cpu", safety_cpu, -1, 1023);
  if (rt_priority > 0 && safety_priority > 0 && safety_priority <= rt_priority) {
    throw ConfigError(
        "realtime.safety_priority", format_value(std::int64_t{safety_priority}),
        "must be above realtime.priority = " + format_value(std::int64_t{rt_priority}) +
            ": the safety thread preempts the acquisition thread");
  }
  require_integer_in_range("realtime.check_interval_us", check_interval_us, 50, 100'000);
  require_integer_in_range("realtime.publish_slack_us", publish_slack_us, 0, 10'000'000);
  require_integer_in_range("realtime.max_consecutive_deadline_misses",
                           max_consecutive_deadline_misses, 0, 1000);
  require_integer_in_range("realtime.stack_prefault_kib", stack_prefault_kib, 16, 65536);
  require_integer_in_range("safety.poll_interval_us", poll_interval_us, 100, 100'000);
  require_integer_in_range("safety.watchdog_toggle_ms", watchdog_toggle_ms, 1, 10'000);
  require_integer_in_range("safety.arming_timeout_ms", arming_timeout_ms, 10, 60'000);
  require_integer_in_range("safety.readback_timeout_ms", readback_timeout_ms, 1, 10'000);
  if (stall_timeout_ms != 0) {
    require_integer_in_range("safety.stall_timeout_ms", stall_timeout_ms, 10, 600'000);
  }
  require_integer_in_range("safety.park_wait_ms", park_wait_ms, 1, 10'000);
  require_integer_in_range("safety.auto_rearm_ms", auto_rearm_ms, 0, 3'600'000);
  if (control_socket.size() >= sizeof(sockaddr_un{}.sun_path)) {
    throw ConfigError("control.socket", quoted(control_socket),
                      "must be shorter than " + std::to_string(sizeof(sockaddr_un{}.sun_path)) +
                          " bytes (a Unix socket path)");
  }
  require_integer_in_range("control.max_clients", max_clients, 1, 64);
  require_integer_in_range("control.idle_timeout_ms", idle_timeout_ms, 100, 86'400'000);
  require_real_in_range("status.interval_s", status_interval_s, 0.05, 3600.0);
  require_real_in_range("simulation.mirror_natural_hz", mirror_natural_hz, 10.0, 100'000.0);
  require_real_in_range("simulation.mirror_damping", mirror_damping, 0.05, 5.0);
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
    if (present.count(key) == 0) missing += (missing.empty() ? "" : ", ") + std::string(key);
  }
  if (c.lines_backend != "simulated") {
    for (const char* key : {"lines.laser_emission.offset", "lines.watchdog.offset"}) {
      if (present.count(key) == 0) missing += (missing.empty() ? "" : ", ") + std::string(key);
    }
  }
  if (missing.empty()) return;
  const std::string backend =
      c.digitizer_backend != "simulated" ? "digitizer.backend = " + quoted(c.digitizer_backend)
      : c.galvo_backend != "simulated"   ? "galvo.backend = " + quoted(c.galvo_backend)
                                         : "lines.backend = " + quoted(c.lines_backend);
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
  toml::table root;
  try {
    root = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    throw ConfigFileError(origin, position_of(e.source()),
                          "not valid TOML: " + quote_input(e.description(), 240));
  }
  const SourcePosition end{
      static_cast<std::uint32_t>(std::count(text.begin(), text.end(), '\n') + 1), 1};
  if (root.empty()) {
    throw ConfigFileError(origin, end,
                          "the configuration is empty (no table, no key): refusing it rather "
                          "than running on defaults");
  }
  KeyPositions present;
  read_tables(root, origin, config, &present);
  require_safety_keys(config, origin, present, end);
  if (positions != nullptr) positions->insert(present.begin(), present.end());
}

void load_config_file(const std::string& path, RtConfig& config, KeyPositions* positions) {
  const std::string text = read_small_file(path, "the configuration file", kMaxConfigBytes);
  // A file cut off part-way (a partial copy) mostly ends inside a line: refused. One cut at a
  // line end still misses its later keys, which with real hardware are required.
  if (!text.empty() && text.back() != '\n') {
    const auto lines = static_cast<std::uint32_t>(std::count(text.begin(), text.end(), '\n') + 1);
    throw ConfigFileError(path, {lines, 1},
                          "the file does not end with a newline: it looks cut off (a partial "
                          "copy?); refusing it");
  }
  load_config_text(text, path, config, positions);
}

}  // namespace ioct::rt
