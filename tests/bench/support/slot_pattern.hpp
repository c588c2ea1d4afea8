// The bytes a benchmark writes into each slot's payload: 64-bit words that differ per slot and
// per position, so a copy from the wrong slot or a torn copy is caught by checking a few words
// (or all of them, on the GPU side).
#pragma once

#include <cstdint>

#if defined(__CUDACC__)
#define IOCT_BENCH_HOST_DEVICE __host__ __device__
#else
#define IOCT_BENCH_HOST_DEVICE
#endif

namespace ioct::bench {

IOCT_BENCH_HOST_DEVICE inline constexpr std::uint64_t slot_pattern_word(std::uint64_t slot,
                                                                        std::uint64_t word) {
  return (slot + 1) * 0x9E3779B97F4A7C15ull ^ word * 0xC2B2AE3D27D4EB4Full;
}

}  // namespace ioct::bench
