// Runs a piece of a test in a forked child with limits, for checks whose failure mode is to hang
// (a blocking open of a FIFO) or to eat memory (an allocation sized by a hostile header): the
// child is killed at the time limit and may be given a data-size limit, so the test reports the
// failure instead of hanging or taking the machine down with it.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

namespace ioct::test_support {

enum class ChildOutcome {
  passed,  // `action` returned true
  failed,  // it returned false, threw, or died
  hung,    // still running at the time limit: killed
};

std::string to_string(ChildOutcome outcome);

struct ChildLimits {
  std::chrono::milliseconds time{5000};
  // RLIMIT_DATA of the child; 0: none. It breaks a sanitizer's shadow memory (kSanitized).
  std::uint64_t data_bytes = 0;
};

ChildOutcome run_in_child(const std::function<bool()>& action, ChildLimits limits = {});

}  // namespace ioct::test_support
