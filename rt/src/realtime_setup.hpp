// What makes the acquisition thread real-time, each step tried and its refusal kept (as an
// errno) so that the process can say once, in one warning, what it runs without.
#pragma once

#include <cstddef>
#include <string>

namespace ioct::rt {

struct RealtimeRequest {
  int fifo_priority = 80;   // SCHED_FIFO priority of the acquisition thread; 0: stay SCHED_OTHER
  int cpu = -1;             // CPU to pin it to; -1: no pinning
  bool lock_memory = true;  // mlockall(MCL_CURRENT | MCL_FUTURE)
};

// errno of each step that was requested and refused; 0 where it worked or was not requested.
struct RealtimeOutcome {
  int fifo_error = 0;
  int affinity_error = 0;
  int memory_lock_error = 0;
  bool complete() const noexcept {
    return fifo_error == 0 && affinity_error == 0 && memory_lock_error == 0;
  }
};

// mlockall(MCL_CURRENT | MCL_FUTURE): returns 0 or errno.
int lock_process_memory() noexcept;

// SCHED_FIFO and CPU affinity for the calling thread; fills the two thread fields of `outcome`.
void make_current_thread_realtime(const RealtimeRequest& request,
                                  RealtimeOutcome& outcome) noexcept;

// Touches `bytes` of the calling thread's stack now, so the loop never faults on it later.
void prefault_stack(std::size_t bytes) noexcept;

// Whether the running kernel is PREEMPT_RT (/sys/kernel/realtime reads 1). Only there does
// SCHED_FIFO bound a thread's wake-up: a stock kernel grants the priority and still lets a busy
// machine wake it milliseconds late.
bool kernel_is_preempt_rt();

// The one warning for an incomplete outcome (empty when complete): what was refused, why, and
// what to grant.
std::string describe_shortfall(const RealtimeRequest& request, const RealtimeOutcome& outcome);

}  // namespace ioct::rt
