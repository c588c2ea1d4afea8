#include "realtime_setup.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>
#include <fstream>

namespace ioct::rt {

int lock_process_memory() noexcept {
  return ::mlockall(MCL_CURRENT | MCL_FUTURE) == 0 ? 0 : errno;
}

void make_current_thread_realtime(const RealtimeRequest& request,
                                  RealtimeOutcome& outcome) noexcept {
  if (request.cpu >= 0) {
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    CPU_SET(static_cast<std::size_t>(request.cpu), &cpus);
    outcome.affinity_error = ::pthread_setaffinity_np(::pthread_self(), sizeof(cpus), &cpus);
  }
  if (request.fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = request.fifo_priority;
    outcome.fifo_error = ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &param);
  }
}

void prefault_stack(std::size_t bytes) noexcept {
  // Volatile stores into a stack area below this frame: the compiler may not drop them, so every
  // page of it is touched.
  volatile unsigned char* area = static_cast<unsigned char*>(__builtin_alloca(bytes));
  for (std::size_t offset = 0; offset < bytes; offset += 4096) area[offset] = 0;
}

bool kernel_is_preempt_rt() {
  std::ifstream in("/sys/kernel/realtime");
  std::string line;
  return in && std::getline(in, line) && line == "1";
}

std::string describe_shortfall(const RealtimeRequest& request, const RealtimeOutcome& outcome) {
  if (outcome.complete()) return {};
  std::string refused;
  std::string remedy;
  const auto add = [&](const std::string& what, int error, const char* fix) {
    refused += (refused.empty() ? "" : "; ") + what + " refused (" + std::strerror(error) + ")";
    remedy += (remedy.empty() ? "" : " and ") + std::string(fix);
  };
  if (outcome.fifo_error != 0) {
    add("SCHED_FIFO priority " + std::to_string(request.fifo_priority), outcome.fifo_error,
        "CAP_SYS_NICE (or LimitRTPRIO=)");
  }
  if (outcome.memory_lock_error != 0) {
    add("mlockall", outcome.memory_lock_error, "CAP_IPC_LOCK (or LimitMEMLOCK=infinity)");
  }
  if (outcome.affinity_error != 0) {
    add("pinning to CPU " + std::to_string(request.cpu), outcome.affinity_error,
        "a CPU this process may use (--cpu)");
  }
  return "running without real-time guarantees: " + refused + ". Grant " + remedy +
         " to run hard real-time; continuing" +
         (outcome.fifo_error != 0 ? " (deadline misses are counted, not treated as faults)." : ".");
}

}  // namespace ioct::rt
