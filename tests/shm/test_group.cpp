#include "test_group.hpp"

#include <cstring>

namespace ioct::ring_test {
namespace {

std::uint64_t mix(std::uint64_t x) noexcept {  // splitmix64's finaliser
  x += 0x9E3779B97F4A7C15u;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9u;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBu;
  return x ^ (x >> 31);
}

std::uint64_t load(std::span<const std::byte> bytes, std::size_t word) noexcept {
  std::uint64_t v = 0;
  std::memcpy(&v, bytes.data() + word * sizeof v, sizeof v);
  return v;
}

void store(std::span<std::byte> bytes, std::size_t word, std::uint64_t v) noexcept {
  std::memcpy(bytes.data() + word * sizeof v, &v, sizeof v);
}

std::uint64_t checksum(std::span<const std::byte> payload, std::size_t words) noexcept {
  std::uint64_t h = 0x243F6A8885A308D3u;
  for (std::size_t i = 0; i < words; ++i) h = mix(h ^ load(payload, i));
  return h;
}

constexpr std::uint64_t kSweepsPerGroup = 1000;

}  // namespace

void write_test_payload(std::span<std::byte> payload, std::uint64_t group,
                        std::uint64_t epoch) noexcept {
  const std::size_t words = payload.size() / sizeof(std::uint64_t);
  store(payload, 0, group);
  store(payload, 1, epoch);
  for (std::size_t i = 2; i + 1 < words; ++i) store(payload, i, mix(group ^ mix(epoch + i)));
  store(payload, words - 1, checksum(payload, words - 1));
}

TestPayload read_test_payload(std::span<const std::byte> payload) noexcept {
  const std::size_t words = payload.size() / sizeof(std::uint64_t);
  TestPayload p;
  if (words < 3) return p;
  p.group = load(payload, 0);
  p.epoch = load(payload, 1);
  p.checksum_ok = load(payload, words - 1) == checksum(payload, words - 1);
  return p;
}

void stamp_test_header(shm::SlotHeader& header, std::uint64_t group) noexcept {
  header.first_sweep_counter = group * kSweepsPerGroup;
  header.bscan_count = 2;
  header.scan_generation = static_cast<std::uint32_t>(group);
  for (std::uint32_t i = 0; i < header.bscan_count; ++i) {
    header.bscans[i].volume_index = group;
    header.bscans[i].bscan_in_volume = i;
  }
}

std::string check_test_header(const shm::SlotHeader& header) {
  const std::uint64_t g = header.group_index;
  if (header.first_sweep_counter != g * kSweepsPerGroup) {
    return "first_sweep_counter " + std::to_string(header.first_sweep_counter) +
           " belongs to another group than group_index " + std::to_string(g);
  }
  if (header.scan_generation != static_cast<std::uint32_t>(g) || header.bscan_count != 2 ||
      header.bscans[0].volume_index != g || header.bscans[1].volume_index != g ||
      header.bscans[1].bscan_in_volume != 1) {
    return "B-scan markers disagree with group_index " + std::to_string(g);
  }
  return {};
}

void publish_test_group(shm::RingWriter& writer) noexcept {
  const shm::RingWriter::Claim claim = writer.claim();
  write_test_payload(claim.payload, claim.group, writer.epoch());
  stamp_test_header(*claim.header, claim.group);
  writer.publish(claim);
}

}  // namespace ioct::ring_test
