// Order statistics of a run of timed samples, the one way every benchmark here reports a
// distribution: nearest-rank percentiles, so each figure is a sample that was really observed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace ioct::bench {

struct LatencySummary {
  std::size_t count = 0;
  double min_ns = 0;
  double p50_ns = 0;
  double p90_ns = 0;
  double p99_ns = 0;
  double p999_ns = 0;
  double max_ns = 0;
  double mean_ns = 0;
};

// Sorts `samples_ns` (hence by value). An empty run gives an all-zero summary.
LatencySummary summarize(std::vector<std::uint64_t> samples_ns);

// Same order statistics for samples that are not integers (e.g. GB/s of repetitions).
double median(std::vector<double> values);

nlohmann::json to_json(const LatencySummary& summary);

// A time in ns printed as milliseconds with `decimals` places, for the benchmarks' tables.
std::string format_ms(double ns, int decimals = 2);

}  // namespace ioct::bench
