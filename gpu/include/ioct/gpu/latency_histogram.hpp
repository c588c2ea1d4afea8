// Latency percentiles in fixed memory: a log-linear histogram (32 linear buckets per power of
// two, so a reported percentile is within 1.6% of the true value) that a long run can feed
// forever without growing.
#pragma once

#include <array>
#include <cstdint>

namespace ioct::gpu {

class LatencyHistogram {
 public:
  void record(std::uint64_t nanoseconds) noexcept;
  void merge(const LatencyHistogram& other) noexcept;
  void reset() noexcept { *this = LatencyHistogram{}; }

  std::uint64_t count() const noexcept { return count_; }
  std::uint64_t max() const noexcept { return max_; }
  std::uint64_t min() const noexcept { return count_ == 0 ? 0 : min_; }
  // The q-quantile (0 <= q <= 1) as the middle of its bucket, clamped to [min, max]; 0 when empty.
  std::uint64_t quantile(double q) const noexcept;

 private:
  static constexpr unsigned kSubBits = 5;  // 32 buckets per power of two
  static constexpr unsigned kSub = 1u << kSubBits;
  static constexpr unsigned kBuckets = (64 - kSubBits + 1) * kSub;

  static unsigned bucket_of(std::uint64_t value) noexcept;
  static std::uint64_t bucket_low(unsigned bucket) noexcept;
  static std::uint64_t bucket_width(unsigned bucket) noexcept;

  std::array<std::uint64_t, kBuckets> buckets_{};
  std::uint64_t count_ = 0;
  std::uint64_t min_ = ~std::uint64_t{0};
  std::uint64_t max_ = 0;
};

}  // namespace ioct::gpu
