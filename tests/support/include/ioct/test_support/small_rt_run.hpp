// ioct-rt on a small simulated geometry, as the process tests run it: 256 samples x 128 A-scans,
// 4 B-scans per group, 8 per volume, no real-time priority (CI runs unprivileged), and the
// simulated laser watchdog at 2 s instead of 100 ms: without real-time priority (a sanitizer's
// build on a loaded machine) the safety thread can be held up longer than 100 ms, which would cut
// emission and stop the scan for the rest of a test. `extra` arguments follow (a status interval,
// a control socket, --seconds, ...).
#pragma once

#include <string>
#include <vector>

namespace ioct::test_support {

inline std::vector<std::string> small_rt_run(const std::string& ring,
                                             const std::vector<std::string>& extra = {}) {
  std::vector<std::string> arguments = {"--ring",
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
                                        "--sim-laser-watchdog-ms",
                                        "2000"};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  return arguments;
}

}  // namespace ioct::test_support
