#include "group_verifier.hpp"

#include "test_group.hpp"

namespace ioct::ring_test {

std::string describe_damage(const shm::SlotHeader& header, std::span<const std::byte> payload,
                            std::uint64_t group, std::uint64_t epoch) {
  // Built only for a report: the stress loops call this for every group.
  const auto at = [group] { return "group " + std::to_string(group) + ": "; };
  const TestPayload p = read_test_payload(payload);
  if (!p.checksum_ok) return at() + "torn payload (checksum mismatch)";
  if (p.group != group || header.group_index != group) {
    return at() + "payload holds group " + std::to_string(p.group) + ", header group_index " +
           std::to_string(header.group_index);
  }
  if (p.epoch != epoch || header.producer_epoch != epoch) {
    return at() + "payload epoch " + std::to_string(p.epoch) + ", header producer_epoch " +
           std::to_string(header.producer_epoch) + ", reader epoch " + std::to_string(epoch);
  }
  if (header.payload_bytes != payload.size()) {
    return at() + "header payload_bytes " + std::to_string(header.payload_bytes) + ", expected " +
           std::to_string(payload.size());
  }
  if (const std::string problem = check_test_header(header); !problem.empty()) {
    return at() + "torn slot header: " + problem;
  }
  if (header.t_publish_ns == 0) return at() + "t_publish_ns was not stamped";
  return {};
}

bool GroupVerifier::check(const shm::SlotHeader& header, std::span<const std::byte> payload,
                          std::uint64_t expected_group, std::uint64_t expected_epoch) {
  std::string problem = describe_damage(header, payload, expected_group, expected_epoch);
  const bool same_epoch = have_last_ && expected_epoch == last_epoch_;
  if (problem.empty() && same_epoch && expected_group <= last_group_) {
    problem = "group " + std::to_string(expected_group) + ": arrived after group " +
              std::to_string(last_group_) + " (stale or out of order)";
  }
  if (!problem.empty()) {
    if (failures_++ == 0) first_failure_ = std::move(problem);
    return false;
  }
  verified_in_epoch_ = same_epoch ? verified_in_epoch_ + 1 : 1;
  have_last_ = true;
  last_group_ = expected_group;
  last_epoch_ = expected_epoch;
  ++verified_;
  return true;
}

}  // namespace ioct::ring_test
