// The simulator's throughput with its synthesis on 0 (inline), 1, 2, ... N worker threads:
// groups acquired back to back, unpaced, as ioct-rt would take them if the sweep rate had no
// limit. The anchor is the sweep rate of the geometry (100 kHz by default): "x rate" is how many
// times real time the simulator sustains, so >= 1 keeps real time and >= 4 covers a sweep four
// times as fast.
//
//   sim_workers_bench [--max-workers N (default: hardware threads)] [--groups 8]
//                     [--samples 1376] [--ascans 512] [--bscans-per-group 16] [--rate 100000]
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <thread>
#include <vector>

#include "host_description.hpp"
#include "ioct/sim/simulated_digitizer.hpp"

int main(int argc, char** argv) {
  using namespace ioct;
  CLI::App app{"sim_workers_bench: simulator A-scans/s against its worker count"};
  std::uint32_t max_workers = std::max(1u, std::thread::hardware_concurrency());
  int groups = 8;
  hal::DigitizerConfig geometry;
  app.add_option("--max-workers", max_workers, "the last worker count measured")
      ->capture_default_str();
  app.add_option("--groups", groups, "groups timed per worker count")->capture_default_str();
  app.add_option("--samples", geometry.samples_per_ascan)->capture_default_str();
  app.add_option("--ascans", geometry.ascans_per_bscan)->capture_default_str();
  app.add_option("--bscans-per-group", geometry.bscans_per_group)->capture_default_str();
  app.add_option("--rate", geometry.ascan_rate_hz, "sweep rate: the anchor")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  std::printf("%s\n", bench::to_text(bench::describe_host()).c_str());
  const double ascans_per_group =
      static_cast<double>(geometry.ascans_per_bscan) * geometry.bscans_per_group;
  // Flyback sweeps take time too: the rate the simulator must sustain in recorded A-scans/s.
  const double needed =
      geometry.ascan_rate_hz * ascans_per_group / static_cast<double>(geometry.sweeps_per_group());
  std::printf(
      "geometry %u samples x %u A-scans x %u B-scans (+%u flyback) at %.0f Hz: real time is "
      "%.0f recorded A-scans/s (%.2f ms per group)\n",
      geometry.samples_per_ascan, geometry.ascans_per_bscan, geometry.bscans_per_group,
      geometry.flyback_sweeps, geometry.ascan_rate_hz, needed,
      1e3 * static_cast<double>(geometry.sweeps_per_group()) / geometry.ascan_rate_hz);
  std::printf("%8s %14s %9s %12s\n", "workers", "A-scans/s", "x rate", "ms/group");

  std::vector<std::uint16_t> payload(geometry.samples_per_group());
  for (std::uint32_t workers = 0; workers <= max_workers; ++workers) {
    sim::SimulationConfig simulation;
    simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
    simulation.workers = workers;
    sim::SimulatedDigitizer digitizer(simulation);
    digitizer.prepare(geometry);
    digitizer.start();
    hal::GroupInfo info;
    digitizer.acquire_group(payload, info);  // fills the pipeline, warms the tables
    const auto t0 = std::chrono::steady_clock::now();
    for (int g = 0; g < groups; ++g) digitizer.acquire_group(payload, info);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    digitizer.stop();
    const double rate = ascans_per_group * groups / seconds;
    std::printf("%8u %14.0f %9.2f %12.2f%s\n", workers, rate, rate / needed, 1e3 * seconds / groups,
                workers == 0 ? "  (inline, the caller's thread)" : "");
    std::fflush(stdout);
  }
  return 0;
}
