// Attaching as a reader that starts before, or outlives, its producer does: retry while the ring
// is missing, still being initialised, or closed and not yet replaced.
#pragma once

#include <chrono>
#include <string>

#include "ioct/shm/ring_reader.hpp"

namespace ioct::ring_test {

// Throws the last RingError when the ring is not ready by `deadline`, and at once for errors
// that waiting does not cure (foreign, corrupt, ...).
shm::RingReader attach_when_ready(const std::string& name, const shm::ReaderOptions& options,
                                  std::chrono::steady_clock::time_point deadline);

}  // namespace ioct::ring_test
