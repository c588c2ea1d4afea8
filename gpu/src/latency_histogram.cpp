#include "ioct/gpu/latency_histogram.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace ioct::gpu {

// Values below 32 have a bucket each; above, the bucket is (power of two, top 5 bits below the
// leading one).
unsigned LatencyHistogram::bucket_of(std::uint64_t value) noexcept {
  if (value < kSub) return static_cast<unsigned>(value);
  const unsigned shift = static_cast<unsigned>(std::bit_width(value)) - 1 - kSubBits;
  return (shift + 1) * kSub + static_cast<unsigned>((value >> shift) - kSub);
}

std::uint64_t LatencyHistogram::bucket_low(unsigned bucket) noexcept {
  if (bucket < kSub) return bucket;
  const unsigned shift = bucket / kSub - 1;
  return (std::uint64_t{kSub} + bucket % kSub) << shift;
}

std::uint64_t LatencyHistogram::bucket_width(unsigned bucket) noexcept {
  return bucket < kSub ? 1 : std::uint64_t{1} << (bucket / kSub - 1);
}

void LatencyHistogram::record(std::uint64_t nanoseconds) noexcept {
  ++buckets_[bucket_of(nanoseconds)];
  ++count_;
  min_ = std::min(min_, nanoseconds);
  max_ = std::max(max_, nanoseconds);
}

void LatencyHistogram::merge(const LatencyHistogram& other) noexcept {
  for (unsigned b = 0; b < kBuckets; ++b) buckets_[b] += other.buckets_[b];
  count_ += other.count_;
  min_ = std::min(min_, other.min_);
  max_ = std::max(max_, other.max_);
}

std::uint64_t LatencyHistogram::quantile(double q) const noexcept {
  if (count_ == 0) return 0;
  q = std::clamp(q, 0.0, 1.0);
  // The rank of the quantile among the sorted samples, 1-based.
  const auto rank = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(count_))));
  std::uint64_t seen = 0;
  for (unsigned b = 0; b < kBuckets; ++b) {
    seen += buckets_[b];
    if (seen >= rank) {
      const std::uint64_t middle = bucket_low(b) + (bucket_width(b) - 1) / 2;
      return std::clamp(middle, min(), max_);
    }
  }
  return max_;
}

}  // namespace ioct::gpu
