// The processes the recorder's process tests run: ioct-rt on a small simulated geometry, and any
// of the project's executables beside the test binary.
#pragma once

#include <string>
#include <vector>

#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/small_rt_run.hpp"

namespace ioct::ringrec::test {

// ioct-rt on the simulator's small geometry (test_support::small_rt_run), status every 5 s.
inline std::vector<std::string> small_rt(const std::string& ring) {
  return test_support::small_rt_run(ring, {"--status-interval", "5"});
}

inline test_support::ChildProcess start(const std::string& program,
                                        const std::vector<std::string>& arguments) {
  return test_support::ChildProcess::spawn(test_support::sibling_executable(program), arguments);
}

}  // namespace ioct::ringrec::test
