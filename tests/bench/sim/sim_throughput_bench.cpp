// The simulator's throughput mode: groups generated once, then replayed into the ring as fast as
// it takes them (no pacing), with a reader copying them out: the load a consumer benchmark
// sees, far above the 100 kHz an instrument delivers.
//
//   sim_throughput_bench [--pregenerate 4] [--seconds 3] [--slots 8] [--samples 1376]
//                        [--ascans 512] [--bscans-per-group 16] [--json FILE]
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "bench_ring_fixture.hpp"
#include "host_description.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/sim/replay_digitizer.hpp"
#include "ioct/sim/simulated_digitizer.hpp"

int main(int argc, char** argv) {
  using namespace ioct;
  CLI::App app{"sim_throughput_bench: pre-generated groups replayed into the ring, unpaced"};
  std::uint64_t pregenerate = 4;
  double seconds = 3.0;
  std::uint64_t slots = 8;
  hal::DigitizerConfig geometry;
  std::string json_path;
  app.add_option("--pregenerate", pregenerate, "groups simulated once and replayed")
      ->capture_default_str();
  app.add_option("--seconds", seconds, "how long to publish")->capture_default_str();
  app.add_option("--slots", slots, "ring slots")->capture_default_str();
  app.add_option("--samples", geometry.samples_per_ascan)->capture_default_str();
  app.add_option("--ascans", geometry.ascans_per_bscan)->capture_default_str();
  app.add_option("--bscans-per-group", geometry.bscans_per_group)->capture_default_str();
  app.add_option("--json", json_path, "also write the figures as JSON");
  CLI11_PARSE(app, argc, argv);

  const bench::HostDescription host = bench::describe_host();
  std::printf("%s\n", bench::to_text(host).c_str());

  sim::SimulationConfig simulation;
  simulation.scan.ascans_per_bscan = geometry.ascans_per_bscan;
  sim::SimulatedDigitizer simulator(simulation);
  simulator.prepare(geometry);
  simulator.start();
  const auto generated_at = std::chrono::steady_clock::now();
  const auto groups = sim::RecordedGroups::generate(simulator, pregenerate);
  const double generate_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - generated_at).count();

  shm::RingGeometry ring_geometry;
  ring_geometry.samples_per_ascan = geometry.samples_per_ascan;
  ring_geometry.ascans_per_bscan = geometry.ascans_per_bscan;
  ring_geometry.bscans_per_group = geometry.bscans_per_group;
  bench::BenchRing ring("sim-throughput", ring_geometry, slots, bench::SlotFill::none);
  const std::uint64_t group_bytes = ring.layout().group_payload_bytes;

  std::atomic<bool> stop{false};
  std::atomic<bool> reader_ready{false};
  std::uint64_t consumed = 0;
  std::uint64_t lapped = 0;
  std::thread reader_thread([&] {
    shm::RingReader reader = ring.attach_reader("sim-throughput");
    std::vector<std::byte> copy(group_bytes);
    shm::SlotHeader header{};
    reader_ready.store(true);
    while (!stop.load(std::memory_order_relaxed)) {
      const shm::PollStatus status = reader.read_next(copy, header);
      if (status == shm::PollStatus::ready) ++consumed;
      if (status == shm::PollStatus::lapped) ++lapped;
    }
  });
  while (!reader_ready.load()) std::this_thread::yield();

  sim::ReplayDigitizer replay(groups);
  replay.prepare(geometry);
  replay.start();
  shm::RingWriter& writer = ring.writer();
  std::uint64_t published = 0;
  const std::uint64_t start_ns = ioct::monotonic_ns();
  const auto end_ns = start_ns + static_cast<std::uint64_t>(seconds * 1e9);
  std::uint64_t now_ns = start_ns;
  while (now_ns < end_ns) {
    const shm::RingWriter::Claim claim = writer.claim();
    hal::GroupInfo info;
    replay.acquire_group(
        std::span<std::uint16_t>(reinterpret_cast<std::uint16_t*>(claim.payload.data()),
                                 claim.payload.size() / 2),
        info);
    claim.header->first_sweep_counter = info.first_sweep_counter;
    writer.publish(claim);
    ++published;
    now_ns = ioct::monotonic_ns();
  }
  const double elapsed_s = static_cast<double>(now_ns - start_ns) * 1e-9;
  stop.store(true);
  reader_thread.join();

  const double rate = static_cast<double>(published) / elapsed_s;
  const double realtime_rate =
      geometry.ascan_rate_hz / static_cast<double>(geometry.sweeps_per_group());
  const double gbps = rate * static_cast<double>(group_bytes) * 1e-9;
  const double consumed_rate = static_cast<double>(consumed) / elapsed_s;
  std::printf(
      "geometry %u x %u x %u (%.1f MiB per group); %llu groups pre-generated in %.2f s "
      "(%.1f ms each)\n",
      geometry.samples_per_ascan, geometry.ascans_per_bscan, geometry.bscans_per_group,
      static_cast<double>(group_bytes) / (1024.0 * 1024.0),
      static_cast<unsigned long long>(pregenerate), generate_s,
      1e3 * generate_s / static_cast<double>(pregenerate));
  std::printf(
      "replay into the ring, unpaced, %.1f s: %.0f groups/s = %.2f GB/s = %.0fx real time "
      "(%.2f groups/s at %.0f Hz)\n",
      elapsed_s, rate, gbps, rate / realtime_rate, realtime_rate, geometry.ascan_rate_hz);
  std::printf("one reader copying out: %.0f groups/s (%.2f GB/s), %llu lapped of %llu published\n",
              consumed_rate, consumed_rate * static_cast<double>(group_bytes) * 1e-9,
              static_cast<unsigned long long>(lapped), static_cast<unsigned long long>(published));
  if (!json_path.empty()) {
    nlohmann::json report{{"host", bench::to_json(host)},
                          {"group_bytes", group_bytes},
                          {"published_groups_per_s", rate},
                          {"published_gb_per_s", gbps},
                          {"times_real_time", rate / realtime_rate},
                          {"consumed_groups_per_s", consumed_rate},
                          {"lapped", lapped},
                          {"published", published}};
    std::ofstream(json_path) << report.dump(2) << "\n";
  }
  return 0;
}
