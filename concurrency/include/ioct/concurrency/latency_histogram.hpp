// Latencies in nanoseconds, counted in fixed memory so that a thread may record forever without
// allocating, locking or blocking: the acquisition thread's wake-ups, the GPU process's stages.
//
// Log-linear buckets: every value below 128 ns has a bucket of its own; above, each power of two
// is cut into 128 equal buckets, so a bucket is at most 1/128 of its values wide and a quantile
// is reported within 0.4%. The edges 2^k us (1000 << k ns) fall on bucket edges, so the
// power-of-two microsecond buckets of ioct-rt's status are exact sums of these. Values from
// 2^36 ns (68.7 s) on share one overflow bucket; max() stays exact.
//
// One thread records (record, merge, reset); any thread may read, or copy the histogram to
// get a snapshot. The counters are atomics the writer updates by a relaxed load and store (no
// locked instruction); a snapshot taken while the writer runs may be a few samples behind in
// some buckets, never torn within a counter.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

namespace ioct {

class LatencyHistogram {
 public:
  static constexpr unsigned kSubBits = 7;
  static constexpr std::uint64_t kSub = std::uint64_t{1} << kSubBits;  // buckets per power of two
  static constexpr unsigned kExactBits = 36;  // values below 2^36 ns have their own buckets
  static constexpr std::size_t kOverflowBucket = (kExactBits - kSubBits + 1) * kSub;
  static constexpr std::size_t kBuckets = kOverflowBucket + 1;

  static constexpr std::size_t bucket_of(std::uint64_t ns) noexcept {
    if (ns < kSub) return static_cast<std::size_t>(ns);
    const unsigned width = static_cast<unsigned>(std::bit_width(ns));
    if (width > kExactBits) return kOverflowBucket;
    const unsigned shift = width - 1 - kSubBits;
    return static_cast<std::size_t>((shift + 1) * kSub + (ns >> shift) - kSub);
  }
  // The smallest value of bucket b.
  static constexpr std::uint64_t bucket_low(std::size_t b) noexcept {
    if (b < kSub) return b;
    if (b >= kOverflowBucket) return std::uint64_t{1} << kExactBits;
    const unsigned shift = static_cast<unsigned>(b / kSub) - 1;
    return (kSub + b % kSub) << shift;
  }
  // One past the largest value of bucket b (the overflow bucket: the largest uint64_t).
  static constexpr std::uint64_t bucket_high(std::size_t b) noexcept {
    if (b >= kOverflowBucket) return std::numeric_limits<std::uint64_t>::max();
    const std::uint64_t width = b < kSub ? 1 : std::uint64_t{1} << (b / kSub - 1);
    return bucket_low(b) + width;
  }
  // True when a bucket starts at `ns`: count_below(ns) is then exact.
  static constexpr bool is_bucket_edge(std::uint64_t ns) noexcept {
    return bucket_low(bucket_of(ns)) == ns;
  }

  LatencyHistogram() = default;
  // A copy is a snapshot: safe while the writer of `other` records.
  LatencyHistogram(const LatencyHistogram& other) noexcept { copy_from(other); }
  LatencyHistogram& operator=(const LatencyHistogram& other) noexcept {
    if (this != &other) copy_from(other);
    return *this;
  }

  // Writer side.
  void record(std::uint64_t ns) noexcept {
    bump(buckets_[bucket_of(ns)], 1);
    bump(count_, 1);
    bump(sum_ns_, ns);
    if (ns < min_.load(std::memory_order_relaxed)) min_.store(ns, std::memory_order_relaxed);
    if (ns > max_.load(std::memory_order_relaxed)) max_.store(ns, std::memory_order_relaxed);
  }
  // Writer side: adds `other`'s samples (a snapshot of it) to these.
  void merge(const LatencyHistogram& other) noexcept {
    for (std::size_t b = 0; b < kBuckets; ++b) bump(buckets_[b], load(other.buckets_[b]));
    bump(count_, load(other.count_));
    bump(sum_ns_, load(other.sum_ns_));
    if (load(other.min_) < load(min_)) min_.store(load(other.min_), std::memory_order_relaxed);
    if (load(other.max_) > load(max_)) max_.store(load(other.max_), std::memory_order_relaxed);
  }
  // Writer side.
  void reset() noexcept {
    for (auto& bucket : buckets_) bucket.store(0, std::memory_order_relaxed);
    count_.store(0, std::memory_order_relaxed);
    sum_ns_.store(0, std::memory_order_relaxed);
    min_.store(kNoMin, std::memory_order_relaxed);
    max_.store(0, std::memory_order_relaxed);
  }

  // Any thread.
  std::uint64_t count() const noexcept { return load(count_); }
  std::uint64_t sum_ns() const noexcept { return load(sum_ns_); }
  std::uint64_t min() const noexcept { return count() == 0 ? 0 : load(min_); }
  std::uint64_t max() const noexcept { return load(max_); }
  double mean_ns() const noexcept {
    const std::uint64_t n = count();
    return n == 0 ? 0.0 : static_cast<double>(sum_ns()) / static_cast<double>(n);
  }
  std::uint64_t bucket_count(std::size_t b) const noexcept { return load(buckets_[b]); }
  // The samples in the buckets that end at or below `ns`: exactly the samples below `ns` when
  // is_bucket_edge(ns).
  std::uint64_t count_below(std::uint64_t ns) const noexcept {
    std::uint64_t below = 0;
    for (std::size_t b = 0; b < kBuckets && bucket_high(b) <= ns; ++b) below += bucket_count(b);
    return below;
  }
  // The q-quantile (0 <= q <= 1): the sample of rank ceil(q * n), as the middle of its bucket
  // clamped to [min, max] (the first and last ranks exactly min and max); 0 when empty.
  std::uint64_t quantile(double q) const noexcept {
    const Rank r = rank_of(q);
    if (r.bucket == kBuckets) return 0;
    if (r.rank == 1) return min();
    if (r.rank == r.total || r.bucket == kOverflowBucket) return max();
    const std::uint64_t middle =
        bucket_low(r.bucket) + (bucket_high(r.bucket) - bucket_low(r.bucket) - 1) / 2;
    return std::clamp(middle, min(), std::max(min(), max()));
  }
  // An upper bound of the q-quantile: the end of its bucket, at most max(); 0 when empty.
  std::uint64_t quantile_upper(double q) const noexcept {
    const Rank r = rank_of(q);
    if (r.bucket == kBuckets) return 0;
    return std::min(bucket_high(r.bucket), max());
  }

 private:
  static constexpr std::uint64_t kNoMin = std::numeric_limits<std::uint64_t>::max();
  using Counter = std::atomic<std::uint64_t>;

  static std::uint64_t load(const Counter& c) noexcept { return c.load(std::memory_order_relaxed); }
  // Only the writer changes a counter, so a load and a store suffice (no read-modify-write).
  static void bump(Counter& c, std::uint64_t by) noexcept {
    c.store(c.load(std::memory_order_relaxed) + by, std::memory_order_relaxed);
  }
  void copy_from(const LatencyHistogram& other) noexcept {
    for (std::size_t b = 0; b < kBuckets; ++b) {
      buckets_[b].store(load(other.buckets_[b]), std::memory_order_relaxed);
    }
    count_.store(load(other.count_), std::memory_order_relaxed);
    sum_ns_.store(load(other.sum_ns_), std::memory_order_relaxed);
    min_.store(load(other.min_), std::memory_order_relaxed);
    max_.store(load(other.max_), std::memory_order_relaxed);
  }
  struct Rank {
    std::uint64_t rank = 0;         // 1-based, among the samples in the buckets
    std::uint64_t total = 0;        // the samples in the buckets
    std::size_t bucket = kBuckets;  // the bucket of that rank; kBuckets when empty
  };
  // The sample of rank ceil(q * n) and its bucket. n is the buckets' total, not count(), so that
  // a snapshot taken mid-record stays consistent.
  Rank rank_of(double q) const noexcept {
    Rank r;
    for (const Counter& bucket : buckets_) r.total += load(bucket);
    if (r.total == 0) return r;
    q = std::clamp(q, 0.0, 1.0);
    r.rank = std::clamp<std::uint64_t>(
        static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(r.total))), 1, r.total);
    std::uint64_t seen = 0;
    for (r.bucket = 0; r.bucket < kOverflowBucket; ++r.bucket) {
      seen += load(buckets_[r.bucket]);
      if (seen >= r.rank) break;
    }
    return r;
  }

  std::array<Counter, kBuckets> buckets_{};
  Counter count_{0};
  Counter sum_ns_{0};
  Counter min_{kNoMin};
  Counter max_{0};
};

}  // namespace ioct
