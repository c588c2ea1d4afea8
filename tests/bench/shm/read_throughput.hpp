// Reader throughput at the default geometry: read_next() copies of whole groups (22.5 MB) out of
// the ring into one reader buffer, against plain memcpy of the same size in the same run.
//
// The writer publishes slots - 1 groups (untimed; it only moves the cursor, the slots keep their
// pattern), then the reader copies them one by one (each read_next timed). The anchors copy the
// same number of groups of the same size, interleaved with the ring copies round by round:
//  - memcpy from a private heap buffer of slots groups, rotating like the ring;
//  - memcpy straight from the ring's slots through the reader's mapping, without the seqlock,
//    which isolates the protocol's own cost from the cost of the shared-memory pages.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "latency_summary.hpp"

namespace ioct::bench {

struct ReadThroughputResult {
  std::uint64_t group_bytes = 0;
  std::uint64_t slot_count = 0;
  LatencySummary ring_read_next;  // ns per group
  LatencySummary anchor_heap_memcpy;
  LatencySummary anchor_slot_memcpy;
  std::uint64_t drops = 0;       // should be 0: the reader is never lapped here
  std::uint64_t bad_copies = 0;  // copies whose pattern spot check failed (must be 0)
};

// GB/s (1e9 bytes/s) of one group copied in `ns`.
double gigabytes_per_second(std::uint64_t bytes, double ns);

ReadThroughputResult measure_read_throughput(std::uint64_t groups, std::uint64_t slot_count);

void print(const ReadThroughputResult& result);
nlohmann::json to_json(const ReadThroughputResult& result);

}  // namespace ioct::bench
