// Writer -> reader hand-off: how long after publish() stamps t_publish_ns a reader spinning on
// begin_read() holds the ticket. Each group is published only after the reader has taken the
// previous one and a short gap has passed, so every sample is an unqueued hand-off.
//
// Anchor, same threads and CPUs in the same run: the writer stores a clock reading into one
// cache line and the reader spins on it: the cost of moving one line between the two cores
// plus a clock read, which no shared-memory hand-off can beat.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "latency_summary.hpp"

namespace ioct::bench {

struct HandoffLatencyResult {
  int writer_cpu = -1;  // -1: not pinned
  int reader_cpu = -1;
  std::uint64_t gap_ns = 0;            // the writer's pause after each hand-off
  LatencySummary ring;                 // begin_read ticket time - t_publish_ns
  LatencySummary publish_with_reader;  // claim + publish while the reader spins
  LatencySummary anchor_cache_line;    // clock value through one cache line
  std::uint64_t drops = 0;             // groups the reader lost (should be 0)
};

HandoffLatencyResult measure_handoff_latency(std::uint64_t handoffs, std::uint64_t gap_ns,
                                             std::uint64_t slot_count);

void print(const HandoffLatencyResult& result);
nlohmann::json to_json(const HandoffLatencyResult& result);

}  // namespace ioct::bench
