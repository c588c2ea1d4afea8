#include "latency_summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

namespace ioct::bench {
namespace {

// Nearest rank: the smallest sample with at least `fraction` of the run at or below it.
template <typename T>
T nearest_rank(const std::vector<T>& sorted, double fraction) {
  const auto n = static_cast<double>(sorted.size());
  const auto rank = static_cast<std::size_t>(std::ceil(fraction * n));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

}  // namespace

LatencySummary summarize(std::vector<std::uint64_t> samples_ns) {
  LatencySummary s;
  if (samples_ns.empty()) return s;
  std::sort(samples_ns.begin(), samples_ns.end());
  s.count = samples_ns.size();
  s.min_ns = static_cast<double>(samples_ns.front());
  s.p50_ns = static_cast<double>(nearest_rank(samples_ns, 0.50));
  s.p90_ns = static_cast<double>(nearest_rank(samples_ns, 0.90));
  s.p99_ns = static_cast<double>(nearest_rank(samples_ns, 0.99));
  s.p999_ns = static_cast<double>(nearest_rank(samples_ns, 0.999));
  s.max_ns = static_cast<double>(samples_ns.back());
  const long double total =
      std::accumulate(samples_ns.begin(), samples_ns.end(), static_cast<long double>(0));
  s.mean_ns = static_cast<double>(total / static_cast<long double>(s.count));
  return s;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return nearest_rank(values, 0.50);
}

nlohmann::json to_json(const LatencySummary& s) {
  return {{"count", s.count},   {"min_ns", s.min_ns},  {"p50_ns", s.p50_ns},
          {"p90_ns", s.p90_ns}, {"p99_ns", s.p99_ns},  {"p999_ns", s.p999_ns},
          {"max_ns", s.max_ns}, {"mean_ns", s.mean_ns}};
}

std::string format_ms(double ns, int decimals) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", decimals, ns * 1e-6);
  return text;
}

}  // namespace ioct::bench
