// The simulator's cost per group, scenario by scenario, against the time the group lasts at the
// sweep rate: it must keep real time on one core at the default geometry.
//
//   sim_model_bench [--groups 12] [--samples 1376] [--ascans 512] [--bscans-per-group 16]
//                   [--flyback 26] [--only NAME] [--json FILE]
//
// CPU time of the calling thread (CLOCK_THREAD_CPUTIME_ID) per acquire_group(), after one
// warm-up group; median, min and max over --groups.
#include <time.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "host_description.hpp"
#include "ioct/scan/scan_builder.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulated_galvo_output.hpp"

namespace {

using namespace ioct;

double thread_cpu_seconds() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Scenario {
  std::string name;
  std::string what;
  std::function<void(sim::SimulationConfig&, hal::DigitizerConfig&)> setup;
  bool galvo = false;  // driven by a simulated galvo output, bidirectional
};

struct Result {
  std::string name;
  double median_ms = 0, min_ms = 0, max_ms = 0, budget_ms = 0;
};

Result measure(const Scenario& scenario, hal::DigitizerConfig geometry, int groups) {
  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  scenario.setup(simulation, geometry);
  auto bench = std::make_shared<sim::SimulatedBench>(simulation.bench);
  std::unique_ptr<sim::SimulatedGalvoOutput> galvo;
  std::optional<scan::ScanPattern> waveform;
  if (scenario.galvo) {
    // Planned as ioct-rt plans a scan, over its default field and within its galvo limits.
    simulation.scan.extent_x = simulation.scan.extent_y =
        static_cast<float>(scan::ScanSpec::kDefaultExtent);
    waveform = scan::plan_raster(simulation.scan, geometry, scan::ScanKind::bidirectional,
                                 scan::GalvoLimits{});
  }
  std::uint64_t written = 0;
  std::vector<hal::GalvoSample> samples(geometry.sweeps_per_group());
  const auto feed = [&] {
    waveform->fill(written, samples);
    written += galvo->write(samples);
  };
  if (scenario.galvo) {
    galvo = std::make_unique<sim::SimulatedGalvoOutput>(bench);
    hal::GalvoOutputConfig output;
    output.fifo_capacity = static_cast<std::uint32_t>(4 * geometry.sweeps_per_group());
    galvo->prepare(output);
    feed();
    feed();
    galvo->start();
  }
  sim::SimulatedDigitizer digitizer(simulation, bench);
  digitizer.prepare(geometry);
  digitizer.start();
  std::vector<std::uint16_t> payload(geometry.samples_per_group());
  hal::GroupInfo info;
  digitizer.acquire_group(payload, info);  // warm the tables into the caches
  std::vector<double> per_group;
  for (int g = 0; g < groups; ++g) {
    if (galvo) feed();  // the scan generator's work, not timed
    const double t0 = thread_cpu_seconds();
    digitizer.acquire_group(payload, info);
    per_group.push_back(thread_cpu_seconds() - t0);
  }
  std::sort(per_group.begin(), per_group.end());
  Result r;
  r.name = scenario.name;
  r.median_ms = 1e3 * per_group[per_group.size() / 2];
  r.min_ms = 1e3 * per_group.front();
  r.max_ms = 1e3 * per_group.back();
  r.budget_ms = 1e3 * static_cast<double>(geometry.sweeps_per_group()) / geometry.ascan_rate_hz;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sim_model_bench: the simulator's CPU time per group against real time"};
  int groups = 12;
  hal::DigitizerConfig geometry;
  std::string only;
  std::string json_path;
  app.add_option("--groups", groups, "timed groups per scenario")->capture_default_str();
  app.add_option("--samples", geometry.samples_per_ascan)->capture_default_str();
  app.add_option("--ascans", geometry.ascans_per_bscan)->capture_default_str();
  app.add_option("--bscans-per-group", geometry.bscans_per_group)->capture_default_str();
  app.add_option("--flyback", geometry.flyback_sweeps)->capture_default_str();
  app.add_option("--only", only, "run one scenario");
  app.add_option("--json", json_path, "also write the figures as JSON");
  CLI11_PARSE(app, argc, argv);
  if (groups < 1) groups = 1;

  const std::vector<Scenario> scenarios{
      {"retina", "default retina, k-clock", [](auto&, auto&) {}},
      {"retina-surgery", "macular hole, membrane, forceps and scraper",
       [](sim::SimulationConfig& s, hal::DigitizerConfig&) {
         s.retina.macular_hole.enabled = true;
         s.retina.membrane.enabled = true;
         s.instruments.push_back({sim::InstrumentKind::forceps,
                                  {0.1f, 0.0f, 0.42f, 180.0f, 20.0f, 20.0f},
                                  {0.2f, 0.0f, 0.0f, 0.01f, 0.01f, 0.0f, 8.0f, 10.0f, 1.0f}});
         s.instruments.push_back(
             {sim::InstrumentKind::scraper, {-0.4f, 0.3f, 0.45f, 200.0f, 25.0f, 0.0f}, {}});
       }},
      {"retina-dispersion", "dispersion mismatch c2 = 10 rad, c3 = 3 rad",
       [](sim::SimulationConfig& s, hal::DigitizerConfig&) {
         s.interferometer.dispersion_c2 = 10.0;
         s.interferometer.dispersion_c3 = 3.0;
       }},
      {"retina-galvo", "bidirectional raster through the simulated galvo (mirror dynamics)",
       [](auto&, auto&) {}, true},
      {"retina-internal-clock", "lambda-linear sampling (non-uniform FFT)",
       [](sim::SimulationConfig&, hal::DigitizerConfig& g) {
         g.clock_source = hal::ClockSource::internal;
       }},
      {"anterior", "anterior segment preset",
       [](sim::SimulationConfig& s, hal::DigitizerConfig&) {
         s.preset = sim::SamplePreset::anterior_segment;
       }},
      {"mirror", "tilted calibration mirror",
       [](sim::SimulationConfig& s, hal::DigitizerConfig&) {
         s.preset = sim::SamplePreset::mirror;
         s.mirror.tilt_x_fraction = 0.3;
       }},
  };

  const bench::HostDescription host = bench::describe_host();
  std::printf("%s\n", bench::to_text(host).c_str());
  std::printf(
      "geometry %u samples x %u A-scans x %u B-scans (+%u flyback) at %.0f Hz, %d groups "
      "per scenario, one thread\n",
      geometry.samples_per_ascan, geometry.ascans_per_bscan, geometry.bscans_per_group,
      geometry.flyback_sweeps, geometry.ascan_rate_hz, groups);
  std::printf("%-22s %9s %9s %9s %9s %8s %9s  %s\n", "scenario", "median", "min", "max", "budget",
              "of core", "MA-scan/s", "");
  nlohmann::json report{{"host", bench::to_json(host)},
                        {"geometry",
                         {{"samples_per_ascan", geometry.samples_per_ascan},
                          {"ascans_per_bscan", geometry.ascans_per_bscan},
                          {"bscans_per_group", geometry.bscans_per_group},
                          {"flyback_sweeps", geometry.flyback_sweeps}}},
                        {"scenarios", nlohmann::json::array()}};
  for (const Scenario& scenario : scenarios) {
    if (!only.empty() && scenario.name != only) continue;
    const Result r = measure(scenario, geometry, groups);
    const double ascans =
        static_cast<double>(geometry.ascans_per_bscan) * geometry.bscans_per_group;
    std::printf("%-22s %6.2f ms %6.2f ms %6.2f ms %6.2f ms %7.1f%% %9.2f  %s\n", r.name.c_str(),
                r.median_ms, r.min_ms, r.max_ms, r.budget_ms, 100.0 * r.median_ms / r.budget_ms,
                ascans / r.median_ms / 1e3, scenario.what.c_str());
    report["scenarios"].push_back({{"name", r.name},
                                   {"what", scenario.what},
                                   {"median_ms", r.median_ms},
                                   {"min_ms", r.min_ms},
                                   {"max_ms", r.max_ms},
                                   {"budget_ms", r.budget_ms}});
  }
  if (!json_path.empty()) std::ofstream(json_path) << report.dump(2) << "\n";
  return 0;
}
