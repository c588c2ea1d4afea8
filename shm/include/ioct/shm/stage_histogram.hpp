// A latency histogram that lives in shared memory: fixed bucket edges known to both sides, so
// ioct-gpu counts into it and ioct-view turns it into a Prometheus histogram without either side
// sending the edges. Trivially copyable; the writer copies it into the frame ring's status under
// the status seqlock.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace ioct::shm {

// Upper edges (inclusive, ns) of the finite buckets: 0.1 ms to 20 s in 1-2-5 steps, wide enough
// for a CUDA stage (a fraction of a millisecond) and a CPU pass on two cores (seconds). The last
// bucket of StageHistogram::counts holds everything above the last edge.
inline constexpr std::array<std::uint64_t, 17> kStageBucketUpperNs{
    100'000,       200'000,       500'000,       1'000'000,      2'000'000,     5'000'000,
    10'000'000,    20'000'000,    50'000'000,    100'000'000,    200'000'000,   500'000'000,
    1'000'000'000, 2'000'000'000, 5'000'000'000, 10'000'000'000, 20'000'000'000};
inline constexpr std::size_t kStageBuckets = kStageBucketUpperNs.size() + 1;

struct StageHistogram {
  std::uint64_t counts[kStageBuckets];  // per bucket, not cumulative
  std::uint64_t sum_ns;
  std::uint64_t count;

  void record(std::uint64_t ns) noexcept {
    std::size_t b = 0;
    while (b < kStageBucketUpperNs.size() && ns > kStageBucketUpperNs[b]) ++b;
    ++counts[b];
    sum_ns += ns;
    ++count;
  }
};

}  // namespace ioct::shm
