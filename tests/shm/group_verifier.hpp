// Checks every group a reader reports intact: the payload is whole (checksum), it is the group
// and epoch the slot header names, the epoch is the reader's, and groups arrive in increasing
// order within an epoch. Any undetected torn or stale read fails one of these.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ioct/shm/ring_layout.hpp"

namespace ioct::ring_test {

// Empty when `payload` and `header` are intact group `group` of `epoch`, else what is wrong.
std::string describe_damage(const shm::SlotHeader& header, std::span<const std::byte> payload,
                            std::uint64_t group, std::uint64_t epoch);

class GroupVerifier {
 public:
  // `expected_group` is the group the reader says it delivered; `expected_epoch` its epoch.
  // Returns false (and keeps the first problem) when anything disagrees.
  bool check(const shm::SlotHeader& header, std::span<const std::byte> payload,
             std::uint64_t expected_group, std::uint64_t expected_epoch);

  std::uint64_t verified() const noexcept { return verified_; }
  std::uint64_t failures() const noexcept { return failures_; }
  const std::string& first_failure() const noexcept { return first_failure_; }
  // Groups verified in the epoch of the last verified group.
  std::uint64_t verified_in_current_epoch() const noexcept { return verified_in_epoch_; }
  std::uint64_t last_epoch() const noexcept { return last_epoch_; }
  std::uint64_t last_group() const noexcept { return last_group_; }

 private:
  std::uint64_t verified_ = 0;
  std::uint64_t failures_ = 0;
  std::string first_failure_;
  bool have_last_ = false;
  std::uint64_t last_group_ = 0;
  std::uint64_t last_epoch_ = 0;
  std::uint64_t verified_in_epoch_ = 0;
};

}  // namespace ioct::ring_test
