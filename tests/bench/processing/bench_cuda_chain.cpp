// ioct-bench-cuda-chain: throughput of the CUDA OCT chain including ingest from a ring, and the
// latency from a group's publish to its pixels being in the device volume.
//
// For each sweep length (1376 and 2048 samples; the default geometry otherwise: 512 A-scans x 16
// B-scans per group), a ring of 8 slots is filled once with simulated retina groups. Then, each
// timed with CLOCK_MONOTONIC over --seconds:
//   ingest + processing   CudaLivePipeline (what ioct-gpu --backend cuda runs) reads a ring
//                         whose writer thread publishes as fast as the reader frees slots
//                         (headers only; the payloads stay): registered read-only mapping,
//                         cudaMemcpyAsync from the slot, seqlock re-check, processing, volume.
//   anchor: pinned H2D    cudaMemcpyAsync of one group from cudaMallocHost memory, back to back:
//                         the PCIe ceiling of ingest, in A-scans/s (median of 7 batches of 40
//                         copies, measured before and after the pipeline; the higher counts).
//   anchor: compute only  the same chain on a group already on the device (what the CuPy chain
//                         anchor of the design measures).
// Latency: the writer publishes one group every --latency-period-us; each sample is the time
// from the slot's t_publish_ns to the pipeline seeing the group's last kernel done.
// tests/bench/processing/run_cuda_chain_bench.sh runs this beside cupy_chain.py and prints the
// ratios.
#include <cuda_runtime.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "device_timing.hpp"
#include "host_description.hpp"
#include "ioct/concurrency/latency_histogram.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/ingest/live_pipeline.hpp"
#include "ioct/gpu/processing/cuda_oct_processor.hpp"
#include "simulated_group_ring.hpp"

namespace {

using namespace ioct;
using namespace ioct::gpu;

struct Options {
  std::vector<std::uint32_t> samples{1376, 2048};
  double seconds = 3.0;
  std::uint32_t slots = 8;
  std::uint32_t in_flight = 3;
  std::uint32_t latency_groups = 1000;
  std::uint32_t latency_period_us = 2000;
  std::string json_path;
};

shm::RingGeometry geometry_for(std::uint32_t samples) {
  shm::RingGeometry g;
  g.samples_per_ascan = samples;
  return g;
}

// Counts groups and records publish -> landed latency.
class Counter final : public LiveEvents {
 public:
  void on_volume(const Volume&, const VolumeInfo&) override {}
  void on_group(const shm::SlotHeader& h, const PlacementResult&) override {
    ++groups;
    const std::uint64_t now = ioct::monotonic_ns();
    latency.record(now > h.t_publish_ns ? now - h.t_publish_ns : 0);
  }
  void on_rejected(const shm::SlotHeader&, const std::string& problem) override {
    throw std::runtime_error("bench group rejected: " + problem);
  }
  void on_restart(bool) override {}
  std::uint64_t groups = 0;
  LatencyHistogram latency;
};

OctProcessorConfig chain_config() {
  OctProcessorConfig c;  // defaults: rolling background, Hann window, 0..40 dB
  return c;
}

struct Throughput {
  double ascans_per_s = 0.0;
  std::uint64_t groups = 0;
  std::uint64_t dropped = 0;
  double seconds = 0.0;
};

// The pipeline against a writer that publishes as fast as slots free up.
Throughput measure_pipeline(bench::SimulatedGroupRing& ring, const shm::RingGeometry& g,
                            const Options& o) {
  LivePipelineOptions options;
  options.host_volumes = false;
  options.groups_in_flight = o.in_flight;
  auto pipeline =
      make_live_pipeline(Backend::cuda, chain_config(),
                         shm::RingReader::attach(ring.name(), {"bench", false}), options);
  Counter counter;
  // Catch up with what the fill published.
  while (pipeline->poll(counter) != shm::PollStatus::empty) {
  }
  const std::uint64_t start_group = ring.published();
  std::atomic<std::uint64_t> done{start_group};  // the group the reader copies next
  std::atomic<bool> stop{false};
  const std::uint64_t margin = ring.slots() - 2;
  std::thread writer([&] {
    while (!stop.load(std::memory_order_relaxed)) {
      if (ring.published() < done.load(std::memory_order_acquire) + margin) {
        ring.publish();
      } else {
        std::this_thread::yield();
      }
    }
  });
  const auto step = [&] {
    pipeline->poll(counter);
    // The writer may run up to slots - 2 groups ahead of the group being copied.
    done.store(pipeline->reader().position(), std::memory_order_release);
  };
  const std::uint64_t warmup_groups = counter.groups + 50;
  while (counter.groups < warmup_groups) step();
  const std::uint64_t t0 = ioct::monotonic_ns();
  const std::uint64_t g0 = counter.groups;
  const shm::ReaderCounters r0 = pipeline->reader().counters();
  std::uint64_t now = t0;
  while (now - t0 < static_cast<std::uint64_t>(o.seconds * 1e9)) {
    step();
    now = ioct::monotonic_ns();
  }
  const std::uint64_t groups = counter.groups - g0;
  const shm::ReaderCounters r1 = pipeline->reader().counters();
  stop.store(true);
  writer.join();
  pipeline->drain(counter);
  Throughput t;
  t.seconds = static_cast<double>(now - t0) * 1e-9;
  t.groups = groups;
  t.dropped = r1.dropped() - r0.dropped();
  t.ascans_per_s = static_cast<double>(groups * g.ascans_per_group()) / t.seconds;
  return t;
}

// Publish one group every period; the pipeline polls; latency per group.
LatencyHistogram measure_latency(bench::SimulatedGroupRing& ring, const Options& o,
                                 std::uint64_t& dropped) {
  auto pipeline = make_live_pipeline(Backend::cuda, chain_config(),
                                     shm::RingReader::attach(ring.name(), {"bench-latency", false}),
                                     LivePipelineOptions{false, o.in_flight});
  Counter counter;
  while (pipeline->poll(counter) != shm::PollStatus::empty) {
  }
  counter.latency.reset();
  const std::uint64_t before = pipeline->reader().counters().dropped();
  std::atomic<bool> finished{false};
  std::thread writer([&] {
    const auto period = std::chrono::microseconds(o.latency_period_us);
    auto next = std::chrono::steady_clock::now();
    for (std::uint32_t i = 0; i < o.latency_groups; ++i) {
      next += period;
      std::this_thread::sleep_until(next);
      ring.publish();
    }
    finished.store(true);
  });
  const std::uint64_t target = counter.groups + o.latency_groups;
  while (counter.groups < target) {
    pipeline->poll(counter);
    if (finished.load() &&
        pipeline->reader().counters().dropped() - before + counter.groups >= target) {
      break;
    }
  }
  writer.join();
  pipeline->drain(counter);
  dropped = pipeline->reader().counters().dropped() - before;
  return counter.latency;
}

// Pinned host -> device copies of one group, back to back, in A-scans/s.
double pinned_h2d_ascans_per_s(const shm::RingGeometry& g) {
  return static_cast<double>(g.ascans_per_group()) /
         (bench::pinned_h2d_copy_ms(g.group_payload_bytes()) * 1e-3);
}

double compute_only_ascans_per_s(const shm::RingGeometry& g) {
  CudaOctProcessor processor(chain_config());
  processor.prepare(g);
  void* raw = nullptr;
  void* volume = nullptr;
  IOCT_CUDA_CHECK(cudaMalloc(&raw, g.group_payload_bytes()));
  IOCT_CUDA_CHECK(cudaMemset(raw, 0x11, g.group_payload_bytes()));
  const std::size_t depth = g.samples_per_ascan / 2;
  IOCT_CUDA_CHECK(
      cudaMalloc(&volume, std::size_t{g.bscans_per_volume} * g.ascans_per_bscan * depth));
  shm::SlotHeader header{};
  DevicePixelTarget target;
  target.pixels = static_cast<std::uint8_t*>(volume);
  const auto run = [&](int groups) {
    for (int i = 0; i < groups; ++i) {
      bench::describe_group(header, g, static_cast<std::uint64_t>(i));
      for (std::uint32_t b = 0; b < g.bscans_per_group; ++b) {
        target.position[b] = static_cast<std::int32_t>(header.bscans[b].bscan_in_volume);
      }
      processor.enqueue_transform(header, static_cast<const std::uint16_t*>(raw), nullptr);
      processor.enqueue_pixels(header, 0, g.bscans_per_group, target);
    }
  };
  run(20);
  constexpr int kGroups = 200;
  const double ms = bench::device_ms(processor.stream(), [&] { run(kGroups); });
  cudaFree(raw);
  cudaFree(volume);
  return static_cast<double>(kGroups) * static_cast<double>(g.ascans_per_group()) / (ms * 1e-3);
}

int run(const Options& o) {
  if (const std::optional<std::string> problem = cuda_device_problem()) {
    std::fprintf(stderr, "ioct-bench-cuda-chain: %s\n", problem->c_str());
    return 2;
  }
  cudaDeviceProp props{};
  IOCT_CUDA_CHECK(cudaGetDeviceProperties(&props, 0));
  const bench::HostDescription host = bench::describe_host();
  std::printf("ioct-bench-cuda-chain\n%sGPU: %s, compute capability %d.%d, %d SMs\n",
              bench::to_text(host).c_str(), props.name, props.major, props.minor,
              props.multiProcessorCount);
  nlohmann::json report = {{"benchmark", "ioct-bench-cuda-chain"},
                           {"host", bench::to_json(host)},
                           {"gpu", props.name},
                           {"seconds", o.seconds},
                           {"groups_in_flight", o.in_flight},
                           {"slots", o.slots},
                           {"results", nlohmann::json::array()}};
  for (const std::uint32_t samples : o.samples) {
    const shm::RingGeometry g = geometry_for(samples);
    std::printf("\n%u samples x %u A-scans x %u B-scans per group (%.1f MB)\n", samples,
                g.ascans_per_bscan, g.bscans_per_group,
                static_cast<double>(g.group_payload_bytes()) / 1e6);
    bench::SimulatedGroupRing ring("chain-" + std::to_string(samples), g, o.slots);
    // The anchor before and after the pipeline's run, so a drift of the link shows.
    const double pinned_before = pinned_h2d_ascans_per_s(g);
    const double compute = compute_only_ascans_per_s(g);
    const Throughput t = measure_pipeline(ring, g, o);
    const double pinned_after = pinned_h2d_ascans_per_s(g);
    const double pinned = std::max(pinned_before, pinned_after);
    std::printf(
        "  ingest + processing (ring -> device volume): %8.2f M A-scans/s  (%llu groups in "
        "%.2f s, %llu dropped)\n",
        t.ascans_per_s / 1e6, static_cast<unsigned long long>(t.groups), t.seconds,
        static_cast<unsigned long long>(t.dropped));
    std::printf(
        "  anchor: pinned H2D copy, back to back:       %8.2f M A-scans/s  (%.1f GB/s; before "
        "%.2f, after %.2f); ratio %.1f%%\n",
        pinned / 1e6, pinned * samples * 2 / 1e9, pinned_before / 1e6, pinned_after / 1e6,
        100.0 * t.ascans_per_s / pinned);
    std::printf("  anchor: processing only (data on device):    %8.2f M A-scans/s\n",
                compute / 1e6);
    std::printf("  target >= 18 M A-scans/s (1376 samples): %s\n",
                samples != 1376 ? "n/a" : (t.ascans_per_s >= 18e6 ? "met" : "NOT met"));
    nlohmann::json result = {{"samples", samples},
                             {"ascans_per_group", g.ascans_per_group()},
                             {"pipeline_ascans_per_s", t.ascans_per_s},
                             {"pipeline_groups", t.groups},
                             {"pipeline_dropped", t.dropped},
                             {"pinned_h2d_ascans_per_s", pinned},
                             {"pinned_h2d_before_ascans_per_s", pinned_before},
                             {"pinned_h2d_after_ascans_per_s", pinned_after},
                             {"compute_only_ascans_per_s", compute}};
    if (samples == o.samples.front()) {
      std::uint64_t dropped = 0;
      const LatencyHistogram latency = measure_latency(ring, o, dropped);
      const auto ms = [&](double q) { return static_cast<double>(latency.quantile(q)) * 1e-6; };
      std::printf(
          "  latency publish -> in the device volume, one group every %u us: p50 %.3f ms, "
          "p99 %.3f ms, max %.3f ms (%llu groups, %llu dropped)\n",
          o.latency_period_us, ms(0.5), ms(0.99), static_cast<double>(latency.max()) * 1e-6,
          static_cast<unsigned long long>(latency.count()),
          static_cast<unsigned long long>(dropped));
      result["latency_ms"] = {{"p50", ms(0.5)},
                              {"p99", ms(0.99)},
                              {"max", static_cast<double>(latency.max()) * 1e-6},
                              {"count", latency.count()},
                              {"period_us", o.latency_period_us},
                              {"dropped", dropped}};
    }
    report["results"].push_back(result);
  }
  if (!o.json_path.empty()) {
    std::ofstream(o.json_path) << report.dump(2) << "\n";
    std::printf("\nresults written to %s\n", o.json_path.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{
      "Throughput of the CUDA OCT chain including ring ingest, and publish -> volume "
      "latency, beside pinned-copy and processing-only anchors"};
  app.add_option("--samples", o.samples, "sweep lengths to measure");
  app.add_option("--seconds", o.seconds, "seconds per throughput measurement");
  app.add_option("--slots", o.slots, "ring slots")->check(CLI::Range(4, 64));
  app.add_option("--in-flight", o.in_flight, "groups in flight on the device")
      ->check(CLI::Range(2, 16));
  app.add_option("--latency-groups", o.latency_groups, "groups timed for latency");
  app.add_option("--latency-period-us", o.latency_period_us, "publish period of the latency run");
  app.add_option("--json", o.json_path, "also write the results as JSON");
  CLI11_PARSE(app, argc, argv);
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ioct-bench-cuda-chain: %s\n", e.what());
    return 1;
  }
}
