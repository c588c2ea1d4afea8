#include "ioct/test_support/page_fault_counter.hpp"

#include <sys/resource.h>

namespace ioct::test_support {

PageFaults thread_page_faults() noexcept {
  rusage usage{};
  if (::getrusage(RUSAGE_THREAD, &usage) != 0) return {};
  return PageFaults{static_cast<std::uint64_t>(usage.ru_minflt),
                    static_cast<std::uint64_t>(usage.ru_majflt)};
}

}  // namespace ioct::test_support
