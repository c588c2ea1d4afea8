#include "read_throughput.hpp"

#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "bench_ring_fixture.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "slot_pattern.hpp"

namespace ioct::bench {

double gigabytes_per_second(std::uint64_t bytes, double ns) {
  return ns > 0 ? static_cast<double>(bytes) / ns : 0.0;  // bytes per ns == GB/s
}

ReadThroughputResult measure_read_throughput(std::uint64_t groups, std::uint64_t slot_count) {
  if (slot_count < 2) throw std::invalid_argument("read throughput: needs at least 2 slots");
  BenchRing ring("throughput", shm::RingGeometry{}, slot_count, SlotFill::pattern);
  shm::RingReader reader = ring.attach_reader("bench-throughput");
  const std::uint64_t group_bytes = ring.layout().group_payload_bytes;

  ReadThroughputResult result;
  result.group_bytes = group_bytes;
  result.slot_count = slot_count;

  // Touched before timing: the reader's buffer and the anchor's private source.
  std::vector<std::byte> destination(group_bytes, std::byte{1});
  std::vector<std::byte> heap_source(group_bytes * slot_count);
  for (std::uint64_t s = 0; s < slot_count; ++s) {
    std::memcpy(heap_source.data() + s * group_bytes, slot_payload(reader, s).data(), group_bytes);
  }

  // The reader starts at the newest group; take it so that it is caught up.
  shm::SlotHeader header{};
  while (reader.read_next(destination, header) == shm::PollStatus::ready) {
  }

  const std::uint64_t per_round = slot_count - 1;
  const std::uint64_t rounds = (groups + per_round - 1) / per_round + 1;  // + 1 warm-up round
  std::vector<std::uint64_t> ring_ns, heap_ns, slot_ns;
  for (std::uint64_t round = 0; round < rounds; ++round) {
    const bool timed = round > 0;
    ring.publish(per_round);
    for (std::uint64_t k = 0; k < per_round; ++k) {
      const std::uint64_t t0 = ioct::monotonic_ns();
      const shm::PollStatus status = reader.read_next(destination, header);
      const std::uint64_t t1 = ioct::monotonic_ns();
      if (status != shm::PollStatus::ready) {
        throw std::runtime_error("read throughput: read_next answered " +
                                 std::to_string(static_cast<int>(status)) + " instead of ready");
      }
      if (!spot_check_pattern(destination, header.group_index % slot_count)) ++result.bad_copies;
      if (timed) ring_ns.push_back(t1 - t0);
    }
    for (std::uint64_t k = 0; k < per_round; ++k) {
      const std::byte* source =
          heap_source.data() + ((round * per_round + k) % slot_count) * group_bytes;
      const std::uint64_t t0 = ioct::monotonic_ns();
      std::memcpy(destination.data(), source, group_bytes);
      const std::uint64_t t1 = ioct::monotonic_ns();
      if (timed) heap_ns.push_back(t1 - t0);
    }
    for (std::uint64_t k = 0; k < per_round; ++k) {
      const std::uint64_t slot = (round * per_round + k) % slot_count;
      const auto source = slot_payload(reader, slot);
      const std::uint64_t t0 = ioct::monotonic_ns();
      std::memcpy(destination.data(), source.data(), group_bytes);
      const std::uint64_t t1 = ioct::monotonic_ns();
      if (!spot_check_pattern(destination, slot)) ++result.bad_copies;
      if (timed) slot_ns.push_back(t1 - t0);
    }
  }
  result.ring_read_next = summarize(ring_ns);
  result.anchor_heap_memcpy = summarize(heap_ns);
  result.anchor_slot_memcpy = summarize(slot_ns);
  result.drops = reader.counters().dropped();
  return result;
}

void print(const ReadThroughputResult& r) {
  std::printf("reader throughput, read_next of %.3f MB groups from %llu slots (GB = 1e9 bytes)\n",
              static_cast<double>(r.group_bytes) / 1e6,
              static_cast<unsigned long long>(r.slot_count));
  std::printf("  %-34s %8s %9s %9s %9s %9s\n", "", "copies", "GB/s p50", "ms p50", "ms p99",
              "ms max");
  const auto row = [&](const char* what, const LatencySummary& s) {
    std::printf("  %-34s %8zu %9.2f %9.3f %9.3f %9.3f\n", what, s.count,
                gigabytes_per_second(r.group_bytes, s.p50_ns), s.p50_ns / 1e6, s.p99_ns / 1e6,
                s.max_ns / 1e6);
  };
  row("ring read_next (seqlock checked)", r.ring_read_next);
  row("anchor: memcpy heap -> buffer", r.anchor_heap_memcpy);
  row("anchor: memcpy slot -> buffer", r.anchor_slot_memcpy);
  const auto ratio = [](const LatencySummary& anchor, const LatencySummary& ring) {
    return ring.p50_ns > 0 ? anchor.p50_ns / ring.p50_ns : 0.0;
  };
  std::printf(
      "  ring / heap memcpy: %.1f%%, ring / slot memcpy: %.1f%% (GB/s at p50); drops %llu, "
      "bad copies %llu\n",
      100.0 * ratio(r.anchor_heap_memcpy, r.ring_read_next),
      100.0 * ratio(r.anchor_slot_memcpy, r.ring_read_next),
      static_cast<unsigned long long>(r.drops), static_cast<unsigned long long>(r.bad_copies));
}

nlohmann::json to_json(const ReadThroughputResult& r) {
  const auto gbps = [&](const LatencySummary& s) {
    return gigabytes_per_second(r.group_bytes, s.p50_ns);
  };
  return {
      {"group_bytes", r.group_bytes},
      {"slot_count", r.slot_count},
      {"ring_read_next", to_json(r.ring_read_next)},
      {"ring_read_next_gbps_p50", gbps(r.ring_read_next)},
      {"anchor_heap_memcpy", to_json(r.anchor_heap_memcpy)},
      {"anchor_heap_memcpy_gbps_p50", gbps(r.anchor_heap_memcpy)},
      {"anchor_slot_memcpy", to_json(r.anchor_slot_memcpy)},
      {"anchor_slot_memcpy_gbps_p50", gbps(r.anchor_slot_memcpy)},
      {"ratio_ring_to_heap_memcpy",
       r.ring_read_next.p50_ns > 0 ? r.anchor_heap_memcpy.p50_ns / r.ring_read_next.p50_ns : 0.0},
      {"drops", r.drops},
      {"bad_copies", r.bad_copies}};
}

}  // namespace ioct::bench
