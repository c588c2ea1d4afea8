// Attaching to a ring that may not be there yet, or that is between two producers: the retry
// loop every long-lived reader (ioct-gpu, ioct-record) runs at start and after the producer went.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "ioct/shm/ring_error.hpp"
#include "ioct/shm/ring_reader.hpp"

namespace ioct::shm {

// True for what a producer starting, restarting or stopping gives (not_found, not_ready,
// producer_gone): worth waiting for. Anything else (squatted, foreign, permission, ...) is not.
bool attach_worth_retrying(RingErrc code) noexcept;

struct AttachWait {
  // CLOCK_MONOTONIC ns after which a bounded wait gives up; ignored when `unbounded`.
  std::uint64_t deadline_ns = 0;
  bool unbounded = false;  // wait for the producer's return as long as it takes (a service)
  const std::atomic<bool>* stop = nullptr;  // set: give up and return nullopt
  std::uint64_t retry_interval_ns = 50'000'000;
  // Called every `report_interval_ns` while an unbounded wait goes on, with the last refusal and
  // the time waited so far; 0 or empty: never.
  std::uint64_t report_interval_ns = 0;
  std::function<void(RingErrc last, std::uint64_t waited_ns)> on_waiting;
};

// Attaches to `name`, retrying refusals worth retrying. Returns nullopt when `stop` was set
// meanwhile. Throws the RingError of a refusal not worth retrying, or, for a bounded wait past
// its deadline, one that says how long it waited (`waited_s` as given) and why.
std::optional<RingReader> attach_when_available(const std::string& name,
                                                const ReaderOptions& options,
                                                const AttachWait& wait, double waited_s = 0.0);

}  // namespace ioct::shm
