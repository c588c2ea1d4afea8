// bench_ring: the CPU figures of the shared-memory ring, each printed beside an anchor measured
// in the same run: writer publish latency, writer -> reader hand-off latency, reader throughput.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "handoff_latency.hpp"
#include "host_description.hpp"
#include "ioct/shm/ring_geometry.hpp"
#include "publish_latency.hpp"
#include "read_throughput.hpp"

namespace {

struct Options {
  std::uint64_t publishes = 1'000'000;
  std::uint64_t handoffs = 100'000;
  std::uint64_t handoff_gap_ns = 5'000;
  std::uint64_t groups = 140;
  std::uint64_t slots = 8;
  bool quick = false;
  std::string json_path;
};

// The smallest ring the layout allows: one page of payload per slot.
ioct::shm::RingGeometry small_geometry() {
  ioct::shm::RingGeometry g;
  g.samples_per_ascan = 64;
  g.ascans_per_bscan = 8;
  g.bscans_per_group = 1;
  g.bscans_per_volume = 1;
  return g;
}

int run(const Options& options) {
  using namespace ioct::bench;
  const HostDescription host = describe_host();
  std::printf("bench_ring: shared-memory ring, CPU side\n%s\n", to_text(host).c_str());

  const PublishLatencyResult small =
      measure_publish_latency("small", small_geometry(), options.slots, options.publishes);
  print(small);
  std::printf("\n");
  const PublishLatencyResult full = measure_publish_latency("default", ioct::shm::RingGeometry{},
                                                            options.slots, options.publishes);
  print(full);
  std::printf("\n");
  const HandoffLatencyResult handoff =
      measure_handoff_latency(options.handoffs, options.handoff_gap_ns, options.slots);
  print(handoff);
  std::printf("\n");
  const ReadThroughputResult throughput = measure_read_throughput(options.groups, options.slots);
  print(throughput);

  if (!options.json_path.empty()) {
    const nlohmann::json report = {{"benchmark", "bench_ring"},
                                   {"host", to_json(host)},
                                   {"options",
                                    {{"publishes", options.publishes},
                                     {"handoffs", options.handoffs},
                                     {"handoff_gap_ns", options.handoff_gap_ns},
                                     {"groups", options.groups},
                                     {"slots", options.slots},
                                     {"quick", options.quick}}},
                                   {"publish_latency", {to_json(small), to_json(full)}},
                                   {"handoff_latency", to_json(handoff)},
                                   {"read_throughput", to_json(throughput)}};
    std::ofstream out(options.json_path);
    out << report.dump(2) << "\n";
    if (!out) {
      std::fprintf(stderr, "bench_ring: cannot write %s\n", options.json_path.c_str());
      return 1;
    }
    std::printf("\nresults written to %s\n", options.json_path.c_str());
  }
  // A copy that failed its check or a lost group makes the figures meaningless.
  if (throughput.bad_copies != 0 || throughput.drops != 0 || handoff.drops != 0) {
    std::fprintf(stderr, "bench_ring: FAILED: %llu bad copies, %llu + %llu groups dropped\n",
                 static_cast<unsigned long long>(throughput.bad_copies),
                 static_cast<unsigned long long>(throughput.drops),
                 static_cast<unsigned long long>(handoff.drops));
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{
      "CPU benchmarks of the shared-memory ring; every figure beside an anchor measured "
      "in the same run"};
  app.add_option("--publishes", options.publishes, "publishes timed per geometry")
      ->check(CLI::PositiveNumber);
  app.add_option("--handoffs", options.handoffs, "writer -> reader hand-offs timed")
      ->check(CLI::PositiveNumber);
  app.add_option("--handoff-gap-ns", options.handoff_gap_ns,
                 "pause of the writer between hand-offs, ns");
  app.add_option("--groups", options.groups, "22.5 MB groups copied per path (throughput)")
      ->check(CLI::PositiveNumber);
  app.add_option("--slots", options.slots, "ring slots")->check(CLI::Range(2, 64));
  app.add_option("--json", options.json_path, "also write the results to this JSON file");
  app.add_flag("--quick", options.quick,
               "a short run (10^5 publishes, 10^4 hand-offs, 21 groups) to check it works");
  CLI11_PARSE(app, argc, argv);
  if (options.quick) {
    options.publishes = std::min<std::uint64_t>(options.publishes, 100'000);
    options.handoffs = std::min<std::uint64_t>(options.handoffs, 10'000);
    options.groups = std::min<std::uint64_t>(options.groups, 21);
  }
  try {
    return run(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_ring: %s\n", e.what());
    return 1;
  }
}
