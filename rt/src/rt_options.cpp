#include "rt_options.hpp"

#include <array>
#include <cmath>
#include <thread>
#include <utility>

#include "ioct/common/config_error.hpp"
#include "ioct/scan/scan_builder.hpp"
#include "ioct/scan/scan_infeasible.hpp"
#include "ioct/sim/instrument_spec.hpp"
#include "rt_keys.hpp"

namespace ioct::rt {

static_assert(RtConfig::kMaxSimulationWorkers == sim::SimulationConfig::kMaxWorkers);

std::uint32_t RtConfig::resolved_simulation_workers() const noexcept {
  if (simulation_workers >= 0) return static_cast<std::uint32_t>(simulation_workers);
  return sim::SimulationConfig::default_workers(std::thread::hardware_concurrency());
}

namespace {

// A bound for typing errors: at 1000x a default group (86 ms) is paced every 86 us.
constexpr double kMaxReplaySpeed = 1000.0;

// The error in the file's terms when the key came from the file and no flag overrode it.
[[noreturn]] void rethrow_located(const RtOptions& options, const KeyPositions& positions,
                                  const std::string& key) {
  if (!options.config.empty()) {
    // An item of a list ("simulation.instruments[1].x") is placed where the list is.
    const std::string placed = key.substr(0, key.find('['));
    const auto at = positions.find(placed);
    if (!options.overrides.contains(placed) && at != positions.end()) {
      try {
        throw;
      } catch (const std::exception& e) {
        throw ConfigFileError(options.config, at->second, e.what());
      }
    }
  }
  throw;
}

// --replay-speed: a multiple of the recorded rate, for a replay only.
double validated_replay_speed(const RtOptions& options) {
  const double speed = options.replay_speed;
  if (!std::isfinite(speed) || speed <= 0.0 || speed > kMaxReplaySpeed) {
    throw ConfigError(
        "replay-speed", format_value(speed),
        "must be a multiple of the recorded rate in (0, " + format_value(kMaxReplaySpeed) + "]");
  }
  if (speed != 1.0 && options.replay.empty()) {
    throw ConfigError("replay-speed", format_value(speed),
                      "paces a replay: give --replay FILE with it");
  }
  return speed;
}

}  // namespace

void add_rt_options(CLI::App& app, RtOptions& options) {
  app.add_option("--config", options.config,
                 "TOML configuration file (see docs/operations.md); flags given override its keys")
      ->check(CLI::ExistingFile);
  app.add_option("--replay", options.replay,
                 "play a recording through the loop instead of acquiring: an HDF5 ring "
                 "recording (ioct-record) or a raw one (STEM.json); its geometry must match")
      ->check(CLI::ExistingFile);
  app.add_flag("--replay-once", options.replay_once,
               "stop at the recording's end (the digitizer reports the source gone) instead of "
               "playing it again");
  app.add_option("--replay-speed", options.replay_speed,
                 "pace the replay at this multiple of the recorded group rate (> 0, up to "
                 "1000; e.g. 2, 8): step it up to find the fastest rate the readers keep up with")
      ->capture_default_str();
  rt_keys().add_flags_to(app, options.overrides);
  app.add_option("--seconds", options.seconds, "run this long, then stop; 0: until SIGINT/SIGTERM")
      ->check(CLI::Range(0.0, 1e9))
      ->capture_default_str();
  app.add_option("--summary", options.summary,
                 "write a JSON summary of the run to this file at exit");
  app.add_flag(
      "--check-config", options.check_config,
      "validate the configuration (and the scan against the galvo limits), print it, exit");
  app.add_flag("--config-keys", options.config_keys,
               "print every configuration key (flag, allowed values, default, meaning) as the "
               "Markdown table of docs/config-keys.md, and exit");
  app.add_flag("--self-test", options.self_test,
               "measure the wake-up latency of a real-time thread (like cyclictest) and exit");
  app.add_option("--self-test-seconds", options.self_test_seconds, "length of the self-test")
      ->check(CLI::Range(0.1, 86400.0))
      ->capture_default_str();
  app.add_option("--self-test-interval-us", options.self_test_interval_us,
                 "period of the self-test's timer")
      ->check(CLI::Range(50, 1'000'000))
      ->capture_default_str();
  app.add_option("--self-test-threshold-us", options.self_test_threshold_us,
                 "the self-test fails when the worst wake-up latency exceeds this")
      ->check(CLI::Range(1, 10'000'000))
      ->capture_default_str();
}

RtSetup make_setup(const RtOptions& options) {
  RtSetup setup;
  RtConfig& config = setup.config;
  KeyPositions positions;
  if (!options.config.empty()) load_config_file(options.config, config, &positions);
  rt_keys().apply(options.overrides, config);

  try {
    config.validate();
    const auto timing = scan::ScanTiming::of(config.digitizer, config.bscans_per_volume);
    // Feasibility: the same check a scan change gets, so a bad config is refused at start-up.
    (void)scan::build_scan_pattern(config.scan, timing, config.galvo_limits);

    setup.digitizer = config.digitizer;

    sim::SimulationConfig& simulation = setup.simulation;
    simulation.scan.ascans_per_bscan = config.digitizer.ascans_per_bscan;
    simulation.scan.bscans_per_volume = config.bscans_per_volume;
    simulation.scan.center_x = static_cast<float>(config.scan.offset_x);
    simulation.scan.center_y = static_cast<float>(config.scan.offset_y);
    simulation.scan.extent_x = static_cast<float>(config.scan.extent_x);
    simulation.scan.extent_y = static_cast<float>(config.scan.extent_y);
    simulation.seed = config.simulation_seed;
    simulation.bench.mirrors.natural_hz = config.mirror_natural_hz;
    simulation.bench.mirrors.damping = config.mirror_damping;
    simulation.bench.watchdog_timeout_ms = config.laser_watchdog_timeout_ms;
    simulation.workers = config.resolved_simulation_workers();
    simulation.instruments.clear();
    for (std::size_t i = 0; i < config.simulation_instruments.size(); ++i) {
      const std::string key = "simulation.instruments[" + std::to_string(i) + "]";
      simulation.instruments.push_back(
          sim::parse_instrument_spec(config.simulation_instruments[i], key));
      simulation.instruments.back().validate(key);
    }
    // Under a real-time acquisition thread the simulator's workers run real-time too, below it.
    simulation.worker_priority = config.rt_priority > 0 ? 1 : 0;
    simulation.validate();

    shm::RingConfig& ring = setup.ring;
    ring.name = config.ring_name;
    ring.geometry.samples_per_ascan = config.digitizer.samples_per_ascan;
    ring.geometry.ascans_per_bscan = config.digitizer.ascans_per_bscan;
    ring.geometry.bscans_per_group = config.digitizer.bscans_per_group;
    ring.geometry.bscans_per_volume = config.bscans_per_volume;
    ring.geometry.bytes_per_sample = sizeof(std::uint16_t);
    ring.slot_count = config.ring_slots;
    ring.group = config.ring_group;
    ring.validate();
  } catch (const ConfigError& e) {
    rethrow_located(options, positions, e.key());
  } catch (const scan::ScanInfeasible& e) {
    rethrow_located(options, positions, e.limit());
  }

  setup.realtime.fifo_priority = config.rt_priority;
  setup.realtime.cpu = config.rt_cpu;
  setup.realtime.lock_memory = config.lock_memory;
  setup.replay_file = options.replay;
  setup.replay_loop = !options.replay_once;
  setup.replay_speed = validated_replay_speed(options);
  return setup;
}

std::string option_for_key(const std::string& key) {
  // Keys that no flag sets alone but a product of flags does (hal::DigitizerConfig::validate).
  if (key == "digitizer.samples_per_group") return "--samples x --ascans x --bscans-per-group";
  if (key == "scan.ascans_per_bscan") return "--ascans";  // the simulator's raster
  return rt_keys().flag_for(key);
}

}  // namespace ioct::rt
