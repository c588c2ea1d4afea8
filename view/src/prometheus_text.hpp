// Writing the Prometheus text exposition format (version 0.0.4): a family's HELP and TYPE lines,
// then its samples. Names and label values are ours (fixed in code) except where noted; label
// values are escaped all the same.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ioct::view::prom {

using Labels = std::vector<std::pair<std::string, std::string>>;

// "# HELP name help" and "# TYPE name type" (counter, gauge, histogram, summary).
void family(std::string& out, std::string_view name, std::string_view type, std::string_view help);
// One sample line: name{labels} value (non-finite values are written as NaN / +Inf / -Inf).
void sample(std::string& out, std::string_view name, const Labels& labels, double value);
// A family of one sample.
void single(std::string& out, std::string_view name, std::string_view type, std::string_view help,
            double value);

// One histogram's samples (the family written by the caller): name_bucket{labels,le=...} for
// every finite edge (seconds, ascending) then le="+Inf", cumulative; name_sum; name_count.
// `counts` has one entry per edge plus the overflow bucket.
void histogram_samples(std::string& out, std::string_view name, const Labels& labels,
                       std::span<const double> upper_edges_s, std::span<const std::uint64_t> counts,
                       double sum_s);

// A label value as the format wants it: backslash, double quote and newline escaped.
std::string escape_label_value(std::string_view value);

}  // namespace ioct::view::prom
