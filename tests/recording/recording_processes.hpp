// The processes the recorder's process tests run: ioct-rt on a small simulated geometry, and any
// of the project's executables beside the test binary.
#pragma once

#include <string>
#include <vector>

#include "ioct/test_support/child_process.hpp"

namespace ioct::ringrec::test {

// ioct-rt on the simulator: 256 samples x 128 A-scans, 4 B-scans per group, 8 per volume.
inline std::vector<std::string> small_rt(const std::string& ring) {
  return {"--ring",
          ring,
          "--samples",
          "256",
          "--ascans",
          "128",
          "--bscans-per-group",
          "4",
          "--bscans-per-volume",
          "8",
          "--rt-priority",
          "0",
          "--status-interval",
          "5"};
}

inline test_support::ChildProcess start(const std::string& program,
                                        const std::vector<std::string>& arguments) {
  return test_support::ChildProcess::spawn(test_support::sibling_executable(program), arguments);
}

}  // namespace ioct::ringrec::test
