// Latencies as the metrics and the benchmarks report them: the last samples kept, percentiles on
// demand. Touched on the io thread only.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace ioct::view {

class LatencyRecord {
 public:
  explicit LatencyRecord(std::size_t keep = 4096) : samples_(keep) {}

  void record(std::uint64_t ns) {
    samples_[count_ % samples_.size()] = ns;
    ++count_;
    sum_ns_ += ns;
  }
  std::uint64_t count() const noexcept { return count_; }
  double sum_seconds() const noexcept { return static_cast<double>(sum_ns_) * 1e-9; }
  // The q-quantile (0..1) of the samples kept, in ns; 0 when there are none.
  std::uint64_t quantile(double q) const {
    const std::size_t n = std::min<std::uint64_t>(count_, samples_.size());
    if (n == 0) return 0;
    std::vector<std::uint64_t> sorted(samples_.begin(), samples_.begin() + n);
    const std::size_t k = std::min(n - 1, static_cast<std::size_t>(q * static_cast<double>(n)));
    std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
    return sorted[k];
  }

 private:
  std::vector<std::uint64_t> samples_;
  std::uint64_t count_ = 0;
  std::uint64_t sum_ns_ = 0;
};

}  // namespace ioct::view
