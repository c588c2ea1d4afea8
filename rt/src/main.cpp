// ioct-rt: the acquisition process. It creates the shared-memory ring, runs the acquisition
// thread that fills it group by group from the digitizer (the simulator for now), and reports
// on stderr what the acquisition and the ring's readers are doing until SIGINT or SIGTERM.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <string>
#include <vector>

#include "acquisition_loop.hpp"
#include "ioct/common/config_error.hpp"
#include "ioct/shm/monotonic_clock.hpp"
#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "rt_options.hpp"
#include "run_summary.hpp"
#include "shutdown_signals.hpp"
#include "status_report.hpp"

namespace {

using namespace ioct;

constexpr int kExitRuntimeError = 1;
constexpr int kExitBadConfig = 2;

void say(const std::string& line) {
  std::fprintf(stderr, "ioct-rt: %s\n", line.c_str());
}

std::string describe_startup(const shm::RingWriter& ring, const rt::RtSetup& setup) {
  const hal::DigitizerConfig& d = setup.digitizer;
  const double group_ms = static_cast<double>(d.sweeps_per_group()) * d.sweep_period_ns() * 1e-6;
  const char* action = ring.startup_action() == shm::StartupAction::created ? "created"
                       : ring.startup_action() == shm::StartupAction::reused_stale
                           ? "reused a dead producer's ring"
                           : "replaced a dead producer's ring";
  char text[512];
  std::snprintf(text, sizeof(text),
                "ring '%s' %s: %llu slots of %.1f MiB, %s; simulated digitizer: %u samples x %u "
                "A-scans (+%u flyback) x %u B-scans per group at %.0f Hz = %.2f ms per group "
                "(%.2f groups/s), %u B-scans per volume, seed %llu",
                ring.config().name.c_str(), action,
                static_cast<unsigned long long>(ring.layout().slot_count),
                static_cast<double>(ring.layout().group_payload_bytes) / (1024.0 * 1024.0),
                ring.memory_locked() ? "memory locked" : "memory not locked", d.samples_per_ascan,
                d.ascans_per_bscan, d.flyback_sweeps, d.bscans_per_group, d.ascan_rate_hz, group_ms,
                1e3 / group_ms, setup.simulation.scan.bscans_per_volume,
                static_cast<unsigned long long>(setup.simulation.seed));
  return text;
}

int run(const rt::RtOptions& options) {
  const rt::ShutdownSignals signals;  // before any thread, so every thread inherits the mask
  // A closed stderr must not kill the process before it has closed the ring.
  std::signal(SIGPIPE, SIG_IGN);
  const rt::RtSetup setup = rt::make_setup(options);

  // The digitizer first: a config it refuses leaves any ring under the name untouched.
  sim::SimulatedDigitizer digitizer(setup.simulation);
  digitizer.prepare(setup.digitizer);
  shm::RingWriter ring = shm::RingWriter::create(setup.ring);
  say(describe_startup(ring, setup));

  rt::AcquisitionLoop::Settings settings;
  settings.context.geometry = setup.digitizer;
  settings.context.scan = setup.simulation.scan;
  settings.context.extra_status = shm::kStatusSimulated | shm::kStatusLaserOn;
  settings.realtime = setup.realtime;
  rt::AcquisitionLoop loop(ring, digitizer, settings);
  const rt::RealtimeOutcome outcome = loop.start();
  if (!outcome.complete()) say("warning: " + rt::describe_shortfall(setup.realtime, outcome));

  const std::uint64_t budget_ns = static_cast<std::uint64_t>(
      static_cast<double>(setup.digitizer.sweeps_per_group()) * setup.digitizer.sweep_period_ns());
  const std::uint64_t interval_ns = static_cast<std::uint64_t>(options.status_interval * 1e9);
  const rt::StatusSample first = rt::sample_status(loop);
  const std::uint64_t started_ns = loop.clock().start_ns();
  const std::uint64_t end_ns = options.seconds > 0.0
                                   ? started_ns + static_cast<std::uint64_t>(options.seconds * 1e9)
                                   : std::numeric_limits<std::uint64_t>::max();
  rt::StatusSample previous = first;
  std::uint64_t next_status_ns = started_ns + interval_ns;
  std::string reason = "--seconds elapsed";
  for (;;) {
    const std::uint64_t now = shm::monotonic_ns();
    const std::uint64_t wake = std::min(next_status_ns, end_ns);
    const int signal_number = signals.wait_for(wake > now ? wake - now : 0);
    if (signal_number != 0) {
      reason = std::string("stopped by ") + (signal_number == SIGINT ? "SIGINT" : "SIGTERM");
      break;
    }
    if (loop.failed() || shm::monotonic_ns() >= end_ns) break;
    if (shm::monotonic_ns() >= next_status_ns) {
      const rt::StatusSample sample = rt::sample_status(loop);
      const std::size_t reaped = ring.reap_dead_readers();
      say(rt::format_status(sample, previous, started_ns, budget_ns, ring.readers(), reaped));
      previous = sample;
      // On the interval grid; after a stall, the next line one interval from now.
      next_status_ns += interval_ns;
      if (next_status_ns <= sample.wall_ns) next_status_ns = sample.wall_ns + interval_ns;
    }
  }

  loop.stop();
  // The readers' counters just before the ring closes, for the summary.
  const std::vector<shm::ReaderReport> readers = ring.readers();
  ring.close();
  const rt::StatusSample last = rt::sample_status(loop);
  if (!options.summary.empty()) {
    rt::write_run_summary(
        options.summary,
        {setup.ring.name, reason, loop.failed() ? loop.failure() : "", first, last, budget_ns},
        readers);
  }
  if (loop.failed()) {
    say("error: acquisition failed: " + loop.failure());
    say(rt::format_summary(last, first, budget_ns) + " | ring '" + setup.ring.name + "' closed");
    return kExitRuntimeError;
  }
  say(reason + " | " + rt::format_summary(last, first, budget_ns) + " | ring '" + setup.ring.name +
      "' closed");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ioct-rt: acquisition process of the live OCT system. Fills the shared-memory ring with "
      "groups of raw B-scans from the simulated digitizer and reports status on stderr."};
  rt::RtOptions options;
  rt::add_rt_options(app, options);
  CLI11_PARSE(app, argc, argv);

  try {
    return run(options);
  } catch (const ioct::ConfigError& e) {
    const std::string option = rt::option_for_error(e.what());
    say(std::string("error: invalid configuration: ") + e.what() +
        (option.empty() ? "" : " (option " + option + ")"));
    return kExitBadConfig;
  } catch (const shm::RingError& e) {
    if (e.code() == shm::RingErrc::bad_config) {
      const std::string option = rt::option_for_error(e.what());
      say(std::string("error: invalid configuration: ") + e.what() +
          (option.empty() ? "" : " (option " + option + ")"));
      return kExitBadConfig;
    }
    say(std::string("error: ") + e.what());
    return kExitRuntimeError;
  } catch (const std::exception& e) {
    say(std::string("error: ") + e.what());
    return kExitRuntimeError;
  }
}
