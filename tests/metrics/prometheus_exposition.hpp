// A strict reader of the Prometheus text exposition format (0.0.4), for the tests of /metrics:
// it accepts only what a scraper can rely on and names the line of anything else. Every sample
// belongs to a family announced by one HELP and one TYPE line before its samples; names and label
// names are valid; no series appears twice; a histogram's buckets per label set have ascending
// edges, cumulative counts, end in le="+Inf", and come with _sum and a _count equal to the last
// bucket; a summary has _sum and _count.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace ioct::metrics_test {

struct Sample {
  std::string name;                           // as written (a histogram's ..._bucket too)
  std::map<std::string, std::string> labels;  // unescaped values
  double value = 0.0;
};

struct Family {
  std::string name;
  std::string type;  // counter, gauge, histogram, summary, untyped
  std::string help;
  std::vector<Sample> samples;
};

struct Exposition {
  std::map<std::string, Family> families;

  bool has(const std::string& family) const { return families.contains(family); }
  // The value of the one sample `name` with exactly `labels`; throws std::out_of_range when
  // there is none.
  double value(const std::string& name,
               const std::map<std::string, std::string>& labels = {}) const;
};

// Throws std::runtime_error("line N: ...") on the first violation.
Exposition parse_exposition(const std::string& text);

}  // namespace ioct::metrics_test
