#include "rt_keys.hpp"

#include "ioct/shm/ring_geometry.hpp"

#include <limits>
#include <string>

namespace ioct::rt {
namespace {

constexpr std::int64_t kU32 = std::numeric_limits<std::uint32_t>::max();
constexpr std::int64_t kI64 = std::numeric_limits<std::int64_t>::max();

void add_ring_keys(config::KeyTable<RtConfig>& k) {
  k.text("ring.name", IOCT_MEMBER(ring_name),
         "the ring readers attach to: a POSIX shm name without '/', or an absolute path to a "
         "file in a directory (/dev/shm/ioct/ring on the appliance)",
         "--ring")
      .integer("ring.slots", IOCT_MEMBER(ring_slots), 2, 4096,
               "slots in the ring, one group each; readers may fall this far behind", "--slots")
      .text("ring.group", IOCT_MEMBER(ring_group),
            "group owning the ring (mode 0640: it reads); empty: this process's", "--group");
}

void add_digitizer_keys(config::KeyTable<RtConfig>& k) {
  k.choice("digitizer.backend", IOCT_MEMBER(digitizer_backend), {"simulated", "usb"},
           "simulated: the simulator's bench (sim/); usb: the instrument of [usb] (hal/usb)")
      .integer("digitizer.samples_per_ascan", IOCT_MEMBER(digitizer.samples_per_ascan), 16, 16384,
               "k-clock samples per sweep (even)", "--samples")
      .integer("digitizer.ascans_per_bscan", IOCT_MEMBER(digitizer.ascans_per_bscan), 1, 65536,
               "recorded sweeps (A-scans) per B-scan", "--ascans")
      .integer("digitizer.flyback_sweeps", IOCT_MEMBER(digitizer.flyback_sweeps), 0, 65536,
               "unrecorded sweeps after each B-scan while the galvo turns", "--flyback")
      .integer("digitizer.bscans_per_group", IOCT_MEMBER(digitizer.bscans_per_group), 1,
               shm::kMaxBscansPerGroup, "B-scans per ring slot (the ring's markers hold 64)",
               "--bscans-per-group")
      .real("digitizer.ascan_rate_hz", IOCT_MEMBER(digitizer.ascan_rate_hz),
            "sweep rate, Hz (1 to 1e7); one galvo sample per sweep", "--ascan-rate")
      .integer("digitizer.sample_bits", IOCT_MEMBER(digitizer.sample_bits), 8, 16,
               "ADC resolution, bits")
      .choice_of(
          "digitizer.clock_source", {"external_k_clock", "internal"},
          [](const RtConfig& c) { return std::string(to_string(c.digitizer.clock_source)); },
          [](RtConfig& c, const std::string& v) {
            c.digitizer.clock_source =
                v == "internal" ? hal::ClockSource::internal : hal::ClockSource::external_k_clock;
          },
          "the sample clock: the swept laser's k-clock, or the digitizer's own")
      .integer("digitizer.timeout_ms", IOCT_MEMBER(digitizer.timeout_ms), 1, 60'000,
               "no record for this long is a stall (a fault)")
      .choice_of(
          "digitizer.trigger.source", {"sweep_input", "software"},
          [](const RtConfig& c) { return std::string(to_string(c.digitizer.trigger.source)); },
          [](RtConfig& c, const std::string& v) {
            c.digitizer.trigger.source =
                v == "software" ? hal::TriggerSource::software : hal::TriggerSource::sweep_input;
          },
          "what starts a record: the laser's sweep trigger input, or software")
      .real("digitizer.trigger.level_volts", IOCT_MEMBER(digitizer.trigger.level_volts),
            "trigger level, V (-5 to 5)")
      .integer("digitizer.trigger.delay_samples", IOCT_MEMBER(digitizer.trigger.delay_samples), 0,
               65536, "samples between the trigger and the record");
}

void add_scan_keys(config::KeyTable<RtConfig>& k) {
  k.choice_of(
       "scan.pattern", {"raster", "bidirectional", "crosshair", "radial"},
       [](const RtConfig& c) { return std::string(to_string(c.scan.kind)); },
       [](RtConfig& c, const std::string& v) { c.scan.kind = *scan::scan_kind_from_string(v); },
       "the galvo pattern (rt/README.md)", "--pattern")
      .integer("scan.bscans_per_volume", IOCT_MEMBER(bscans_per_volume), 1, 65536,
               "B-scans per volume, fixed for the ring's life", "--bscans-per-volume")
      .integer("scan.repeats", IOCT_MEMBER(scan.repeats), 1, 65536,
               "B-scans per line (averaging, OCTA); divides bscans_per_volume (crosshair: into "
               "an even number of lines)")
      .real("scan.extent_x", IOCT_MEMBER(scan.extent_x),
            "half-width of the field, scan units (0 to 1; +-1 is the scanner's full range)")
      .real("scan.extent_y", IOCT_MEMBER(scan.extent_y), "half-height of the field (0 to 1)")
      .real("scan.offset_x", IOCT_MEMBER(scan.offset_x), "centre of the field, x (-1 to 1)")
      .real("scan.offset_y", IOCT_MEMBER(scan.offset_y), "centre of the field, y (-1 to 1)")
      .real("scan.rotation_deg", IOCT_MEMBER(scan.rotation_deg),
            "rotation, degrees counter-clockwise (-360 to 360)")
      .integer("scan.inactive_ascans", IOCT_MEMBER(scan.inactive_ascans), 0, 32767,
               "recorded A-scans at each end outside the active range (more time to turn); "
               "fewer than ascans_per_bscan / 2");
}

void add_galvo_keys(config::KeyTable<RtConfig>& k) {
  k.choice("galvo.backend", IOCT_MEMBER(galvo_backend), {"simulated", "usb"},
           "usb streams through the digitizer's instrument (needs digitizer.backend = usb)")
      .integer("galvo.fifo_capacity", IOCT_MEMBER(galvo.fifo_capacity), 16, 1 << 24,
               "DAC samples held ahead; more than one group of sweeps")
      .real_in("galvo.lead_us", IOCT_MEMBER(galvo_lead_us), 0.0, 100'000.0,
               "galvo lead compensation, us: DAC sample n carries sweep n + lead (111.4 us is the "
               "simulated mirrors' lag 2 zeta / omega; measure yours); at most fifo_capacity / 2 "
               "sweeps")
      .real("galvo.park_x", IOCT_MEMBER(galvo.park.x),
            "where the beam rests when not scanning, x (-1 to 1)")
      .real("galvo.park_y", IOCT_MEMBER(galvo.park.y), "where the beam rests, y (-1 to 1)")
      .real("galvo.max_velocity", IOCT_MEMBER(galvo_limits.max_velocity),
            "scan units per second, per axis (> 0)")
      .real("galvo.max_acceleration", IOCT_MEMBER(galvo_limits.max_acceleration),
            "scan units per second squared, per axis (> 0)")
      .integer("galvo.feed_ahead_groups", IOCT_MEMBER(feed_ahead_groups), 1, 64,
               "the DAC FIFO is topped up to this many groups (capped by the FIFO)");
}

void add_usb_keys(config::KeyTable<RtConfig>& k) {
  k.integer("usb.vendor_id", IOCT_MEMBER(usb_vendor_id), 1, 0xFFFF,
            "the instrument's USB vendor ID (a placeholder; keep the udev rule equal)")
      .integer("usb.product_id", IOCT_MEMBER(usb_product_id), 0, 0xFFFF,
               "the instrument's USB product ID")
      .text("usb.serial", IOCT_MEMBER(usb_serial),
            "pick one instrument by serial number; empty: the first found");
}

void add_lines_keys(config::KeyTable<RtConfig>& k) {
  k.choice("lines.backend", IOCT_MEMBER(lines_backend), {"simulated", "gpio"},
           "simulated, or gpio (libgpiod, hal/gpio)")
      .text("lines.chip", IOCT_MEMBER(lines.chip), "GPIO chip name or path")
      .text("lines.consumer", IOCT_MEMBER(lines.consumer), "label the lines are requested under");
  // Each line's wiring; no two lines on one offset (hal::LinesConfig::validate).
#define IOCT_WIRING(line, what)                                                  \
  k.integer("lines." #line ".offset", IOCT_MEMBER(lines.line.offset), 0, 1023,   \
            "GPIO offset of the " what " line")                                  \
      .boolean("lines." #line ".active_low", IOCT_MEMBER(lines.line.active_low), \
               "the " what " line is active low");
  IOCT_WIRING(laser_emission, "laser emission (out)")
  IOCT_WIRING(watchdog, "external watchdog heartbeat (out)")
  IOCT_WIRING(laser_ready, "laser ready (in)")
  IOCT_WIRING(sweep_trigger_present, "sweep trigger present (in)")
  IOCT_WIRING(k_clock_valid, "k-clock valid (in)")
  IOCT_WIRING(footswitch, "footswitch (in)")
#undef IOCT_WIRING
}

void add_realtime_keys(config::KeyTable<RtConfig>& k) {
  k.integer("realtime.priority", IOCT_MEMBER(rt_priority), 0, 99,
            "SCHED_FIFO priority of the acquisition thread; 0: none", "--rt-priority")
      .integer("realtime.cpu", IOCT_MEMBER(rt_cpu), -1, 1023,
               "CPU to pin the acquisition thread to (the isolated one); -1: none", "--cpu")
      .boolean("realtime.lock_memory", IOCT_MEMBER(lock_memory),
               "mlockall(MCL_CURRENT | MCL_FUTURE)")
      .integer("realtime.safety_priority", IOCT_MEMBER(safety_priority), -1, 99,
               "the safety thread's, above priority; -1: priority + 5 (max 99), 0: none")
      .integer("realtime.safety_cpu", IOCT_MEMBER(safety_cpu), -1, 1023,
               "CPU to pin the safety thread to; -1: none")
      .integer("realtime.check_interval_us", IOCT_MEMBER(check_interval_us), 50, 100'000,
               "how often a waiting acquisition thread looks at its command")
      .integer("realtime.publish_slack_us", IOCT_MEMBER(publish_slack_us), 0, 10'000'000,
               "a group published later than this after its last sweep is a deadline miss")
      .integer("realtime.max_consecutive_deadline_misses",
               IOCT_MEMBER(max_consecutive_deadline_misses), 0, 1000,
               "more in a row is a fault (SCHED_FIFO only)")
      .integer("realtime.stack_prefault_kib", IOCT_MEMBER(stack_prefault_kib), 16, 65536,
               "stack touched before the loop starts");
}

void add_safety_keys(config::KeyTable<RtConfig>& k) {
  k.integer("safety.poll_interval_us", IOCT_MEMBER(poll_interval_us), 100, 100'000,
            "the safety thread's poll (it also wakes on every input edge)")
      .integer("safety.watchdog_toggle_ms", IOCT_MEMBER(watchdog_toggle_ms), 1, 10'000,
               "heartbeat period of the external watchdog line")
      .integer("safety.arming_timeout_ms", IOCT_MEMBER(arming_timeout_ms), 10, 60'000,
               "start to verified emission, or a fault")
      .integer("safety.readback_timeout_ms", IOCT_MEMBER(readback_timeout_ms), 1, 10'000,
               "emission command to its read-back")
      .integer("safety.stall_timeout_ms", IOCT_MEMBER(stall_timeout_ms), 0, 600'000,
               "acquisition heartbeat age that is a stall (0, or at least 10); 0: one group + "
               "digitizer.timeout_ms + 100 ms")
      .integer("safety.park_wait_ms", IOCT_MEMBER(park_wait_ms), 1, 10'000,
               "a faulted acquisition thread parks on its own after this")
      .integer("safety.max_missed_sweeps_per_group", IOCT_MEMBER(max_missed_sweeps_per_group), 0,
               kU32, "more missed sweeps in a group is a trigger loss")
      .boolean("safety.monitor_laser_ready", IOCT_MEMBER(monitor_laser_ready),
               "fault when laser ready drops (off only where a bench has it unwired)")
      .boolean("safety.monitor_k_clock", IOCT_MEMBER(monitor_k_clock),
               "fault when the k-clock is lost")
      .boolean("safety.monitor_sweep_trigger", IOCT_MEMBER(monitor_sweep_trigger),
               "fault when the sweep trigger is lost")
      .boolean("safety.require_footswitch", IOCT_MEMBER(require_footswitch),
               "emit only while the footswitch is pressed")
      .integer("safety.auto_rearm_ms", IOCT_MEMBER(auto_rearm_ms), 0, 3'600'000,
               "re-arm from safe by itself after this; 0: only on a start command");
}

void add_control_keys(config::KeyTable<RtConfig>& k) {
  k.text("control.socket", IOCT_MEMBER(control_socket),
         "Unix socket of the control channel, JSON lines (/run/ioct/rt.sock on the appliance); "
         "empty: none",
         "--control-socket")
      .text("control.socket_group", IOCT_MEMBER(control_group),
            "group of the control socket (mode 0660); empty: this process's")
      .boolean("control.start_scanning", IOCT_MEMBER(start_scanning),
               "arm at start-up; false: wait for a start command (with real hardware the file "
               "must set it)")
      .integer("control.max_clients", IOCT_MEMBER(max_clients), 1, 64,
               "clients of the control socket at once")
      .integer("control.idle_timeout_ms", IOCT_MEMBER(idle_timeout_ms), 100, 86'400'000,
               "a client that sends no request for this long is closed");
}

void add_status_keys(config::KeyTable<RtConfig>& k) {
  k.real_in("status.interval_s", IOCT_MEMBER(status_interval_s), 0.05, 3600.0,
            "seconds between status lines on stderr", "--status-interval");
}

void add_simulation_keys(config::KeyTable<RtConfig>& k) {
  k.integer("simulation.seed", IOCT_MEMBER(simulation_seed), 0, kI64,
            "the simulator's seed: same seed, same bytes", "--seed")
      .real_in("simulation.mirror_natural_hz", IOCT_MEMBER(mirror_natural_hz), 10.0, 100'000.0,
               "the simulated galvo servo's bandwidth, Hz")
      .real_in("simulation.mirror_damping", IOCT_MEMBER(mirror_damping), 0.05, 5.0,
               "the simulated galvo servo's damping ratio")
      .integer("simulation.laser_watchdog_timeout_ms", IOCT_MEMBER(laser_watchdog_timeout_ms), 0,
               60'000, "the simulated external laser watchdog's timeout", "--sim-laser-watchdog-ms")
      .integer_or_auto("simulation.workers", IOCT_MEMBER(simulation_workers), 0,
                       RtConfig::kMaxSimulationWorkers,
                       "threads synthesising the simulated groups ahead (sim/README.md); auto: "
                       "hardware threads - 3, 1 to 8; 0: on the acquisition thread")
      .text_list("simulation.instruments", IOCT_MEMBER(simulation_instruments),
                 "instruments in the simulated scene (at most 4), one KIND[:name=value,...] "
                 "each: KIND forceps, needle or scraper, names as sim/instrument_spec.hpp "
                 "lists them",
                 "--sim-instrument");
}

config::KeyTable<RtConfig> make_keys() {
  config::KeyTable<RtConfig> k;
  add_ring_keys(k);
  add_digitizer_keys(k);
  add_scan_keys(k);
  add_galvo_keys(k);
  add_usb_keys(k);
  add_lines_keys(k);
  add_realtime_keys(k);
  add_safety_keys(k);
  add_control_keys(k);
  add_status_keys(k);
  add_simulation_keys(k);
  return k;
}

}  // namespace

const config::KeyTable<RtConfig>& rt_keys() {
  static const config::KeyTable<RtConfig> keys = make_keys();
  return keys;
}

}  // namespace ioct::rt
