// summary.json: what a run of ioct-gpu did, for people and for scripts (tests, CI, benches).
#pragma once

#include <nlohmann/json.hpp>

#include "ioct/gpu/ingest/live_processor.hpp"

namespace ioct::gpu {

// Latencies in milliseconds, paths absolute, rates per second. Keys:
//   ring, backend, threads, db_min, db_max, stop_reason, seconds, geometry{...},
//   groups{consumed, processed, dropped_lapped, dropped_behind, rejected, resyncs, epoch_changes},
//   groups_per_second, ascans_per_second, bscans_rejected,
//   volumes{completed, with_gaps, abandoned}, latency_ms{count, p50, p99, max},
//   images{bscan, enface, volume_index, complete, bscans_missing, bscan_shown, zero_fraction,
//          saturated_fraction} or null, images_written, images_replaced, image_errors,
//          status_flags_seen[],
//   last_problem.
nlohmann::json to_json(const RunSummary& summary);

}  // namespace ioct::gpu
