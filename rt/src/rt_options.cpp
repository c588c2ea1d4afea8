#include "rt_options.hpp"

#include <array>
#include <utility>

namespace ioct::rt {

void add_rt_options(CLI::App& app, RtOptions& options) {
  app.add_option("--ring", options.ring, "name of the shared-memory ring (POSIX shm, no '/')")
      ->capture_default_str();
  app.add_option("--slots", options.slots, "slots in the ring, each one group")
      ->capture_default_str();
  app.add_option("--samples", options.samples, "k-clock samples per A-scan (even)")
      ->capture_default_str();
  app.add_option("--ascans", options.ascans, "recorded A-scans per B-scan")->capture_default_str();
  app.add_option("--flyback", options.flyback,
                 "sweeps between B-scans while the galvo returns (not recorded)")
      ->capture_default_str();
  app.add_option("--bscans-per-group", options.bscans_per_group, "B-scans per ring slot")
      ->capture_default_str();
  app.add_option("--bscans-per-volume", options.bscans_per_volume, "B-scans per volume")
      ->capture_default_str();
  app.add_option("--ascan-rate", options.ascan_rate, "sweep rate of the source, Hz")
      ->capture_default_str();
  app.add_option("--seconds", options.seconds, "run this long, then stop; 0: until SIGINT/SIGTERM")
      ->check(CLI::Range(0.0, 1e9))
      ->capture_default_str();
  app.add_option("--group", options.group,
                 "group that owns the ring (readers need it); default: this process's");
  app.add_option("--summary", options.summary,
                 "write a JSON summary of the run to this file at exit");
  app.add_option("--seed", options.seed, "seed of the simulation: same seed, same bytes")
      ->capture_default_str();
  app.add_option("--status-interval", options.status_interval,
                 "seconds between status lines on stderr")
      ->check(CLI::Range(0.05, 3600.0))
      ->capture_default_str();
  app.add_option("--rt-priority", options.rt_priority,
                 "SCHED_FIFO priority of the acquisition thread; 0: none")
      ->check(CLI::Range(0, 99))
      ->capture_default_str();
  app.add_option("--cpu", options.cpu, "CPU to pin the acquisition thread to; -1: none")
      ->check(CLI::Range(-1, 1023))
      ->capture_default_str();
}

RtSetup make_setup(const RtOptions& options) {
  RtSetup setup;
  hal::DigitizerConfig& digitizer = setup.digitizer;
  digitizer.samples_per_ascan = options.samples;
  digitizer.ascans_per_bscan = options.ascans;
  digitizer.flyback_sweeps = options.flyback;
  digitizer.bscans_per_group = options.bscans_per_group;
  digitizer.ascan_rate_hz = options.ascan_rate;
  digitizer.clock_source = hal::ClockSource::external_k_clock;
  digitizer.validate();

  setup.simulation.scan.ascans_per_bscan = options.ascans;
  setup.simulation.scan.bscans_per_volume = options.bscans_per_volume;
  setup.simulation.seed = options.seed;
  setup.simulation.validate();

  shm::RingConfig& ring = setup.ring;
  ring.name = options.ring;
  ring.geometry.samples_per_ascan = options.samples;
  ring.geometry.ascans_per_bscan = options.ascans;
  ring.geometry.bscans_per_group = options.bscans_per_group;
  ring.geometry.bscans_per_volume = options.bscans_per_volume;
  ring.geometry.bytes_per_sample = sizeof(std::uint16_t);
  ring.slot_count = options.slots;
  ring.group = options.group;
  ring.validate();

  setup.realtime.fifo_priority = options.rt_priority;
  setup.realtime.cpu = options.cpu;
  return setup;
}

std::string option_for_error(const std::string& message) {
  static constexpr std::array<std::pair<const char*, const char*>, 14> kOptions{{
      {"digitizer.samples_per_group", "--samples x --ascans x --bscans-per-group"},
      {"digitizer.samples_per_ascan", "--samples"},
      {"digitizer.ascans_per_bscan", "--ascans"},
      {"digitizer.flyback_sweeps", "--flyback"},
      {"digitizer.bscans_per_group", "--bscans-per-group"},
      {"digitizer.ascan_rate_hz", "--ascan-rate"},
      {"scan.ascans_per_bscan", "--ascans"},
      {"scan.bscans_per_volume", "--bscans-per-volume"},
      {"ring: name", "--ring"},
      {"slot_count", "--slots"},
      {"samples_per_ascan", "--samples"},
      {"bscans_per_group", "--bscans-per-group"},
      {"bscans_per_volume", "--bscans-per-volume"},
      {"ascans_per_bscan", "--ascans"},
  }};
  for (const auto& [key, option] : kOptions) {
    if (message.find(key) != std::string::npos) return option;
  }
  return {};
}

}  // namespace ioct::rt
