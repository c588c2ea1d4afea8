#include "publish_latency.hpp"

#include <algorithm>
#include <cstdio>
#include <vector>

#include "bench_ring_fixture.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "ioct/test_support/page_fault_counter.hpp"

namespace ioct::bench {

PublishLatencyResult measure_publish_latency(const std::string& label,
                                             const shm::RingGeometry& geometry,
                                             std::uint64_t slot_count, std::uint64_t publishes) {
  BenchRing ring("publish-" + label, geometry, slot_count, SlotFill::none);
  shm::RingWriter& writer = ring.writer();

  PublishLatencyResult result;
  result.label = label;
  result.group_payload_bytes = ring.layout().group_payload_bytes;
  result.slot_count = slot_count;
  result.memory_locked = writer.memory_locked();

  // Allocated and touched before timing, so the loop itself faults on nothing of ours.
  std::vector<std::uint64_t> samples(publishes, 1);

  // Warm-up: caches, branch predictors and the vDSO page.
  const std::uint64_t warmup = std::min<std::uint64_t>(publishes, 10'000);
  for (std::uint64_t i = 0; i < warmup; ++i) writer.publish(writer.claim());

  const test_support::PageFaultCounter faults;
  const test_support::AllocationCounter allocations;
  for (std::uint64_t i = 0; i < publishes; ++i) {
    const std::uint64_t t0 = ioct::monotonic_ns();
    const auto claim = writer.claim();
    writer.publish(claim);
    samples[i] = ioct::monotonic_ns() - t0;
  }
  const test_support::PageFaults loop_faults = faults.faults();
  result.heap_allocations = allocations.allocations();
  result.minor_page_faults = loop_faults.minor;
  result.major_page_faults = loop_faults.major;
  result.per_publish = summarize(samples);

  const std::uint64_t batch_start = ioct::monotonic_ns();
  for (std::uint64_t i = 0; i < publishes; ++i) writer.publish(writer.claim());
  result.batch_mean_ns = static_cast<double>(ioct::monotonic_ns() - batch_start) /
                         static_cast<double>(std::max<std::uint64_t>(publishes, 1));

  for (std::uint64_t i = 0; i < publishes; ++i) {
    const std::uint64_t t0 = ioct::monotonic_ns();
    samples[i] = ioct::monotonic_ns() - t0;
  }
  result.timer_floor = summarize(samples);
  return result;
}

void print(const PublishLatencyResult& r) {
  std::printf("publish latency, writer side, %s (%.3f MB groups, %llu slots, memory %s)\n",
              r.label.c_str(), static_cast<double>(r.group_payload_bytes) / 1e6,
              static_cast<unsigned long long>(r.slot_count),
              r.memory_locked ? "locked" : "prefaulted, not locked");
  std::printf("  %-30s %9s %9s %9s %9s %9s\n", "", "p50 ns", "p99 ns", "p99.9 ns", "max ns",
              "mean ns");
  const auto row = [](const char* what, const LatencySummary& s) {
    std::printf("  %-30s %9.0f %9.0f %9.0f %9.0f %9.1f\n", what, s.p50_ns, s.p99_ns, s.p999_ns,
                s.max_ns, s.mean_ns);
  };
  row("claim+publish (timed each)", r.per_publish);
  row("anchor: clock pair alone", r.timer_floor);
  std::printf("  %-30s %49.1f\n", "claim+publish (batch mean)", r.batch_mean_ns);
  std::printf(
      "  median net of the clock pair: %.0f ns (target <= 1000 ns); in the timed loop: "
      "%llu minor + %llu major page faults, %llu heap allocations\n",
      r.per_publish.p50_ns - r.timer_floor.p50_ns,
      static_cast<unsigned long long>(r.minor_page_faults),
      static_cast<unsigned long long>(r.major_page_faults),
      static_cast<unsigned long long>(r.heap_allocations));
}

nlohmann::json to_json(const PublishLatencyResult& r) {
  return {{"label", r.label},
          {"group_payload_bytes", r.group_payload_bytes},
          {"slot_count", r.slot_count},
          {"memory_locked", r.memory_locked},
          {"per_publish", to_json(r.per_publish)},
          {"batch_mean_ns", r.batch_mean_ns},
          {"anchor_clock_pair", to_json(r.timer_floor)},
          {"minor_page_faults", r.minor_page_faults},
          {"major_page_faults", r.major_page_faults},
          {"heap_allocations", r.heap_allocations}};
}

}  // namespace ioct::bench
