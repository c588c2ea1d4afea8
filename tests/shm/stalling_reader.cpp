#include "stalling_reader.hpp"

#include <random>
#include <thread>
#include <vector>

namespace ioct::ring_test {

StallingReadResult read_stalling(shm::RingReader& reader, std::uint64_t end_group, ReadApi api,
                                 const StallPlan& plan,
                                 std::chrono::steady_clock::time_point deadline) {
  StallingReadResult result;
  result.start_position = reader.position();
  std::mt19937_64 rng(plan.seed);
  std::uniform_real_distribution<double> coin(0.0, 1.0);
  std::uniform_int_distribution<std::int64_t> stall_us(0, plan.max_stall.count());
  const auto maybe_stall = [&] {
    if (plan.stall_probability > 0.0 && coin(rng) < plan.stall_probability) {
      ++result.stalls;
      std::this_thread::sleep_for(std::chrono::microseconds(stall_us(rng)));
    }
  };

  std::vector<std::byte> buffer(reader.layout().group_payload_bytes);
  const std::span<std::byte> whole(buffer);
  const std::size_t half = buffer.size() / 2;
  shm::SlotHeader header{};
  shm::ReadTicket ticket;
  std::uint64_t polls = 0;
  bool idle = false;  // the last poll found nothing
  auto idle_since = std::chrono::steady_clock::now();
  while (reader.position() < end_group) {
    if ((++polls & 0xFF) == 0 && std::chrono::steady_clock::now() > deadline) break;
    maybe_stall();
    shm::PollStatus status;
    if (api == ReadApi::copy) {
      status = reader.read_next(whole, header);
      if (status == shm::PollStatus::ready) {
        result.verifier.check(header, whole, reader.position() - 1, reader.epoch());
      }
    } else {
      status = reader.begin_read(ticket);
      if (status == shm::PollStatus::ready) {
        // Copy in two halves with a possible stall between them, so the writer gets to overwrite
        // the slot in the middle of a copy.
        shm::seqlock_copy(buffer.data(), ticket.payload, half);
        maybe_stall();
        shm::seqlock_copy(buffer.data() + half, ticket.payload + half, buffer.size() - half);
        if (reader.end_read(ticket)) {
          // The reader's epoch, not the ticket's: a ticket from another epoch must not pass.
          result.verifier.check(ticket.header, whole, ticket.group, reader.epoch());
        } else {
          status = shm::PollStatus::lapped;
          if (!describe_damage(ticket.header, whole, ticket.group, ticket.epoch).empty()) {
            ++result.rejected_copies_damaged;
          }
        }
      }
    }
    if (status == shm::PollStatus::lapped) ++result.lapped_polls;
    if (status == shm::PollStatus::producer_gone) {
      result.producer_gone = true;
      break;
    }
    if (status != shm::PollStatus::empty) {
      idle = false;
    } else if (plan.idle_sleep.count() > 0) {
      std::this_thread::sleep_for(plan.idle_sleep);
    } else {
      const auto now = std::chrono::steady_clock::now();
      if (!idle) {
        idle = true;
        idle_since = now;
      } else if (now - idle_since > std::chrono::microseconds(50)) {
        std::this_thread::yield();
      }
    }
  }
  reader.heartbeat();  // the status object shows the final counters
  result.caught_up = reader.position() >= end_group;
  result.end_position = reader.position();
  result.epoch = reader.epoch();
  result.counters = reader.counters();
  return result;
}

}  // namespace ioct::ring_test
