#include "run_summary.hpp"

#include <nlohmann/json.hpp>

#include "ioct/common/atomic_file.hpp"

namespace ioct::rt {

void write_run_summary(const std::string& path, const RunSummary& s,
                       std::span<const shm::ReaderReport> readers) {
  const LoopCounters& c = s.end.counters;
  const double ms = 1e-6;
  nlohmann::json readers_json = nlohmann::json::array();
  for (const shm::ReaderReport& r : readers) {
    readers_json.push_back({{"label", r.label},
                            {"pid", r.pid},
                            {"alive", r.alive},
                            {"consumed", r.counters.consumed},
                            {"dropped_lapped", r.counters.dropped_lapped},
                            {"dropped_behind", r.counters.dropped_behind}});
  }
  const std::uint64_t groups = c.groups_generated;
  const nlohmann::json json = {
      {"ring", s.ring},
      {"stop_reason", s.stop_reason},
      {"failure", s.failure},
      {"replay_error", s.replay_error},
      {"replay_earlier_error", s.replay_earlier_error},
      {"seconds", static_cast<double>(s.end.wall_ns - s.start.wall_ns) * 1e-9},
      {"groups_published", c.groups_published},
      {"groups_generated", c.groups_generated},
      {"deadline_misses", c.deadline_misses},
      {"worst_lateness_ms", static_cast<double>(c.worst_lateness_ns) * ms},
      {"generation_ms_mean",
       groups == 0 ? 0.0
                   : static_cast<double>(c.generation_ns_total) * ms / static_cast<double>(groups)},
      {"generation_ms_max", static_cast<double>(c.generation_ns_max) * ms},
      {"group_budget_ms", static_cast<double>(s.group_budget_ns) * ms},
      {"missed_sweeps", c.missed_sweeps},
      {"simulator_late_groups", c.simulator_late_groups},
      {"simulator_worst_lateness_ms", static_cast<double>(c.simulator_worst_lateness_ns) * ms},
      {"readers_at_close", readers_json},
      {"status", status_json(s.end, s.start.wall_ns, s.group_budget_ns, s.safety, readers)}};

  write_text_file_atomically(path, json.dump(2) + "\n");
}

}  // namespace ioct::rt
