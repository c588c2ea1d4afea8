// Which CPUs this process may run on, and pinning the calling thread to one of them, so that a
// writer and a reader measured against each other sit on different cores.
#pragma once

#include <vector>

namespace ioct::bench {

// The CPUs in this process's affinity mask, in ascending order.
std::vector<int> allowed_cpus();

// Pins the calling thread to `cpu`; false when the kernel refuses (the thread stays unpinned).
bool pin_this_thread(int cpu);

}  // namespace ioct::bench
