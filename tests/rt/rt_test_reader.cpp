// A plain ring reader for the multi-process tests: attaches (waiting for the ring), prints
// "attached" on stdout, then reads every group it can until the producer goes or it is killed.
//   rt_test_reader RING LABEL
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: rt_test_reader RING LABEL\n");
    return 2;
  }
  using namespace std::chrono_literals;
  const auto give_up = std::chrono::steady_clock::now() + 20s;
  for (;;) {
    try {
      ioct::shm::RingReader reader = ioct::shm::RingReader::attach(argv[1], {.label = argv[2]});
      std::printf("attached\n");
      std::fflush(stdout);
      std::vector<std::byte> payload(reader.layout().group_payload_bytes);
      ioct::shm::SlotHeader header{};
      for (;;) {
        const ioct::shm::PollStatus status = reader.read_next(payload, header);
        if (status == ioct::shm::PollStatus::producer_gone) return 0;
        if (status != ioct::shm::PollStatus::ready) std::this_thread::sleep_for(1ms);
      }
    } catch (const ioct::shm::RingError&) {
      if (std::chrono::steady_clock::now() > give_up) return 1;
      std::this_thread::sleep_for(10ms);
    }
  }
}
