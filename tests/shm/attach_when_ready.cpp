#include "attach_when_ready.hpp"

#include <thread>

#include "ioct/shm/ring_error.hpp"

namespace ioct::ring_test {

shm::RingReader attach_when_ready(const std::string& name, const shm::ReaderOptions& options,
                                  std::chrono::steady_clock::time_point deadline) {
  for (;;) {
    try {
      return shm::RingReader::attach(name, options);
    } catch (const shm::RingError& e) {
      const bool transient = e.code() == shm::RingErrc::not_found ||
                             e.code() == shm::RingErrc::not_ready ||
                             e.code() == shm::RingErrc::producer_gone;
      if (!transient || std::chrono::steady_clock::now() > deadline) throw;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace ioct::ring_test
