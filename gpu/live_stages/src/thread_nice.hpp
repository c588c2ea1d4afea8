// The stages' threads run below the processing: each lowers its own priority, since on Linux a
// thread's nice value is its own (threads it starts afterwards inherit it).
#pragma once

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace ioct::gpu::live {

// Sets the calling thread's nice value (0-19); best effort: a refusal leaves it as it was.
inline void set_this_thread_nice(int nice) {
  (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), nice);
}

}  // namespace ioct::gpu::live
