// Time to simulate one group at a geometry, against the time the group lasts at the sweep rate:
// the simulator must keep real time on one core.
//
//   sim_group_bench [groups] [samples] [ascans] [bscans_per_group]
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "ioct/sim/simulated_digitizer.hpp"

namespace {

double cpu_seconds() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  const int groups = argc > 1 ? std::atoi(argv[1]) : 24;
  ioct::hal::DigitizerConfig geometry;
  if (argc > 2) geometry.samples_per_ascan = static_cast<std::uint32_t>(std::atoi(argv[2]));
  if (argc > 3) geometry.ascans_per_bscan = static_cast<std::uint32_t>(std::atoi(argv[3]));
  if (argc > 4) geometry.bscans_per_group = static_cast<std::uint32_t>(std::atoi(argv[4]));
  ioct::sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;

  ioct::sim::SimulatedDigitizer digitizer(simulation);
  digitizer.prepare(geometry);
  digitizer.start();
  std::vector<std::uint16_t> payload(geometry.samples_per_group());
  ioct::hal::GroupInfo info;
  digitizer.acquire_group(payload, info);  // warm the tables into the caches

  std::vector<double> per_group;
  for (int g = 0; g < groups; ++g) {
    const double t0 = cpu_seconds();
    digitizer.acquire_group(payload, info);
    per_group.push_back(cpu_seconds() - t0);
  }
  std::sort(per_group.begin(), per_group.end());
  const double budget = static_cast<double>(geometry.sweeps_per_group()) / geometry.ascan_rate_hz;
  const double median = per_group[per_group.size() / 2];
  std::printf(
      "geometry %u samples x %u A-scans x %u B-scans (+%u flyback) at %.0f Hz, %d groups\n"
      "generation CPU time per group: median %.2f ms, min %.2f ms, max %.2f ms\n"
      "real-time budget per group: %.2f ms -> %.1f%% of one core, %.2f M A-scans/s\n",
      geometry.samples_per_ascan, geometry.ascans_per_bscan, geometry.bscans_per_group,
      geometry.flyback_sweeps, geometry.ascan_rate_hz, groups, 1e3 * median,
      1e3 * per_group.front(), 1e3 * per_group.back(), 1e3 * budget, 100.0 * median / budget,
      static_cast<double>(geometry.ascans_per_bscan) * geometry.bscans_per_group / median / 1e6);
  return 0;
}
