// How the ring tests fill a group so that a reader can tell an intact group from a torn or a
// stale one without knowing anything else:
//   payload word 0      the group index
//   payload word 1      the producer epoch
//   payload words 2..   a pattern derived from both
//   last payload word   a checksum of every word before it
// and the slot header carries values derived from the group index (first sweep counter, B-scan
// markers), so a header mixed from two groups is caught too.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ioct/shm/ring_layout.hpp"
#include "ioct/shm/ring_writer.hpp"

namespace ioct::ring_test {

// 8 samples x 4 A-scans x 2 B-scans x 2 bytes: a 128-byte group, so that a million groups take
// a second and slots turn over fast enough for readers to be lapped often.
inline shm::RingGeometry small_test_geometry() {
  shm::RingGeometry g;
  g.samples_per_ascan = 8;
  g.ascans_per_bscan = 4;
  g.bscans_per_group = 2;
  g.bscans_per_volume = 8;
  g.bytes_per_sample = 2;
  return g;
}

inline shm::RingConfig small_test_config(const std::string& name, std::uint64_t slot_count = 8) {
  shm::RingConfig config;
  config.name = name;
  config.geometry = small_test_geometry();
  config.slot_count = slot_count;
  return config;
}

// Payload sizes must be a multiple of 8 bytes and at least 24.
void write_test_payload(std::span<std::byte> payload, std::uint64_t group,
                        std::uint64_t epoch) noexcept;

struct TestPayload {
  std::uint64_t group = 0;
  std::uint64_t epoch = 0;
  bool checksum_ok = false;  // the words match each other: the payload is one group's, whole
};
TestPayload read_test_payload(std::span<const std::byte> payload) noexcept;

// Producer-owned header fields the tests set from the group index.
void stamp_test_header(shm::SlotHeader& header, std::uint64_t group) noexcept;
// Empty when the producer-owned fields agree with header.group_index, else what disagrees.
std::string check_test_header(const shm::SlotHeader& header);

// claim + write_test_payload + stamp_test_header + publish: one group, as a producer does it.
void publish_test_group(shm::RingWriter& writer) noexcept;

}  // namespace ioct::ring_test
