// Writer-side cost of claim() + publish() with no reader: the producer's hot path. The payload
// is not filled, so what is timed is the ring protocol alone.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "ioct/shm/ring_geometry.hpp"
#include "latency_summary.hpp"

namespace ioct::bench {

struct PublishLatencyResult {
  std::string label;
  std::uint64_t group_payload_bytes = 0;
  std::uint64_t slot_count = 0;
  bool memory_locked = false;
  LatencySummary per_publish;  // one clock read pair around each claim + publish
  double batch_mean_ns = 0;    // one clock read pair around the whole loop, divided
  LatencySummary timer_floor;  // the same clock read pair around nothing: the anchor
  // During the timed per-publish loop, on the writer's thread (the design's steady state: 0).
  std::uint64_t minor_page_faults = 0;
  std::uint64_t major_page_faults = 0;
  std::uint64_t heap_allocations = 0;
};

PublishLatencyResult measure_publish_latency(const std::string& label,
                                             const shm::RingGeometry& geometry,
                                             std::uint64_t slot_count, std::uint64_t publishes);

void print(const PublishLatencyResult& result);
nlohmann::json to_json(const PublishLatencyResult& result);

}  // namespace ioct::bench
