// A reader loop for the stress tests: reads until it has caught up with a writer that publishes a
// known number of groups, stalling at random, and verifies every group it is handed.
#pragma once

#include <chrono>
#include <cstdint>

#include "group_verifier.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::ring_test {

enum class ReadApi {
  copy,    // read_next(): the reader library copies
  ticket,  // begin_read(), copy, end_read(): the zero-copy path, with stalls in mid-copy
};

struct StallPlan {
  std::uint64_t seed = 1;
  double stall_probability = 0.0;  // per poll: sleep up to max_stall
  std::chrono::microseconds max_stall{0};
  // When there is nothing to read: 0 polls again at once, giving the CPU away only after 50 us
  // of nothing (keeps up with a fast writer: a reader that yielded at every empty poll would
  // wait out whole time slices of other processes on a busy machine); more sleeps that long
  // (leaves the CPU to a slow writer).
  std::chrono::microseconds idle_sleep{0};
};

struct StallingReadResult {
  std::uint64_t start_position = 0;  // the reader's position when the loop began
  std::uint64_t end_position = 0;
  std::uint64_t epoch = 0;
  shm::ReaderCounters counters;
  GroupVerifier verifier;
  std::uint64_t stalls = 0;
  std::uint64_t lapped_polls = 0;
  // Copies end_read() rejected that were really damaged (torn or overwritten): proof that the
  // race the seqlock guards against happened and that the checks above would catch it.
  std::uint64_t rejected_copies_damaged = 0;
  bool caught_up = false;
  bool producer_gone = false;
};

// Polls until reader.position() reaches `end_group`, the producer goes away, or `deadline`.
StallingReadResult read_stalling(shm::RingReader& reader, std::uint64_t end_group, ReadApi api,
                                 const StallPlan& plan,
                                 std::chrono::steady_clock::time_point deadline);

}  // namespace ioct::ring_test
