// The housekeeping side's view of the acquisition: samples of the loop's counters, the safety
// state and the process's CPU time, turned into the periodic status line (the journal), the
// control channel's status object and the final summary.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "acquisition_loop.hpp"
#include "ioct/shm/reader_status.hpp"
#include "safety_supervisor.hpp"

namespace ioct::rt {

struct StatusSample {
  std::uint64_t wall_ns = 0;  // CLOCK_MONOTONIC
  std::uint64_t cpu_ns = 0;   // user + system CPU time of the whole process
  LoopCounters counters;
  LatencyHistogram wake_latency;
};

// User plus system CPU time this process has used, all threads.
std::uint64_t process_cpu_ns() noexcept;
StatusSample sample_status(const AcquisitionLoop& loop) noexcept;

// "12.0 s | scanning | groups 139 (11.62/s) | misses 0 | gen 19.8 ms avg, 23.1 ms max of 86.1 ms |
//  wake p99 64 us, max 80 us | dac min 17216 | cpu 23.5% | readers: gpu pid 4242 alive consumed
//  138 dropped 0 hb 4 ms"
std::string format_status(const StatusSample& now, const StatusSample& previous,
                          std::uint64_t started_ns, std::uint64_t group_budget_ns,
                          const SafetyStatus& safety, std::span<const shm::ReaderReport> readers,
                          std::size_t reaped);

// The last words: how long it ran, what it published, how the timing held, the CPU it used.
std::string format_summary(const StatusSample& end, const StatusSample& start,
                           std::uint64_t group_budget_ns);

// The status as JSON (the control channel's "status" reply, the summary's core).
nlohmann::json status_json(const StatusSample& now, std::uint64_t started_ns,
                           std::uint64_t group_budget_ns, const SafetyStatus& safety,
                           std::span<const shm::ReaderReport> readers);

}  // namespace ioct::rt
