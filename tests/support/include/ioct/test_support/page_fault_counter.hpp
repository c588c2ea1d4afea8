// Page faults taken by the calling thread (getrusage RUSAGE_THREAD), so a test can show that a
// real-time path touches only memory that is already mapped.
#pragma once

#include <cstdint>

namespace ioct::test_support {

struct PageFaults {
  std::uint64_t minor = 0;  // served without I/O (first touch, copy-on-write, ...)
  std::uint64_t major = 0;  // needed I/O
  std::uint64_t total() const noexcept { return minor + major; }
};

// Page faults the calling thread has taken since it started.
PageFaults thread_page_faults() noexcept;

// Counts the calling thread's page faults from construction on. Use it on one thread only.
class PageFaultCounter {
 public:
  PageFaultCounter() noexcept : at_start_(thread_page_faults()) {}

  PageFaults faults() const noexcept {
    const PageFaults now = thread_page_faults();
    return PageFaults{now.minor - at_start_.minor, now.major - at_start_.major};
  }

 private:
  PageFaults at_start_;
};

}  // namespace ioct::test_support
