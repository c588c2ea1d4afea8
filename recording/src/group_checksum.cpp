#include <cstring>

#include "ioct/ringrec/ring_recording_format.hpp"

namespace ioct::ringrec {

std::uint64_t group_checksum(std::span<const std::byte> payload) noexcept {
  constexpr std::uint64_t kOffset = 14695981039346656037ull;
  constexpr std::uint64_t kPrime = 1099511628211ull;
  std::uint64_t hash = kOffset;
  const std::size_t words = payload.size() / 8;
  const std::byte* data = payload.data();
  for (std::size_t i = 0; i < words; ++i) {
    std::uint64_t word;
    std::memcpy(&word, data + 8 * i, 8);  // x86-64 and aarch64 Linux: little-endian
    hash = (hash ^ word) * kPrime;
  }
  if (const std::size_t tail = payload.size() % 8; tail != 0) {
    std::uint64_t word = 0;
    std::memcpy(&word, data + 8 * words, tail);
    hash = (hash ^ word) * kPrime;
  }
  return hash;
}

}  // namespace ioct::ringrec
