// Small random number generators whose output is fixed by their definition (unlike
// std::*_distribution, whose algorithms each standard library picks), so a seed means the same
// stream wherever the simulator is built.
#pragma once

#include <cmath>
#include <cstdint>

namespace ioct::sim {

// SplitMix64: seeds the stream generator and hashes coordinates to frozen random values.
constexpr std::uint64_t splitmix64(std::uint64_t x) noexcept {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Uniform in (0, 1]: never 0, so log() of it is finite.
inline double unit_open_zero(std::uint64_t bits) noexcept {
  return static_cast<double>((bits >> 11) + 1) * 0x1.0p-53;
}

// xoshiro256** (Blackman and Vigna): the stream of per-A-scan random numbers.
class Xoshiro256 {
 public:
  explicit Xoshiro256(std::uint64_t seed = 0) noexcept { reseed(seed); }

  void reseed(std::uint64_t seed) noexcept {
    std::uint64_t x = seed;
    for (std::uint64_t& word : state_) {
      x = splitmix64(x);
      word = x;
    }
  }

  std::uint64_t next() noexcept {
    const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  // Uniform integer in [0, bound), bound > 0 (multiply-shift; the bias is below 2^-32 for the
  // bounds used here).
  std::uint32_t below(std::uint32_t bound) noexcept {
    return static_cast<std::uint32_t>(((next() >> 32) * bound) >> 32);
  }

  double unit() noexcept { return unit_open_zero(next()); }

  // Standard normal by Box-Muller (one of the pair; used only where speed does not matter).
  double normal() noexcept {
    const double radius = std::sqrt(-2.0 * std::log(unit()));
    return radius * std::cos(6.283185307179586 * unit());
  }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) noexcept {
    return (x << k) | (x >> (64 - k));
  }
  std::uint64_t state_[4]{};
};

}  // namespace ioct::sim
