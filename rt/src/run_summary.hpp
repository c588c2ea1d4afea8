// The machine-readable end of a run (--summary FILE): what ioct-rt published and how its timing
// and its safety held, for the launcher and the end-to-end tests to check against what the
// readers got.
#pragma once

#include <span>
#include <string>

#include "ioct/shm/reader_status.hpp"
#include "status_report.hpp"

namespace ioct::rt {

struct RunSummary {
  std::string ring;
  std::string stop_reason;
  std::string failure;       // empty when the acquisition did not fail
  std::string replay_error;  // why a replay stopped before its recording's end; empty otherwise
  // The first group an earlier arming of the replay could not read, where it differs from
  // replay_error (a re-arm played the recording again): kept, but not the cause of this stop.
  std::string replay_earlier_error;
  StatusSample start;
  StatusSample end;
  std::uint64_t group_budget_ns = 0;
  SafetyStatus safety;
};

// Writes the summary as JSON to `path` atomically (AtomicFile): a reader never sees half of it.
// Throws std::runtime_error naming the path when it cannot.
void write_run_summary(const std::string& path, const RunSummary& summary,
                       std::span<const shm::ReaderReport> readers);

}  // namespace ioct::rt
