#include "prometheus_text.hpp"

#include <cmath>
#include <cstdio>

namespace ioct::view::prom {
namespace {

std::string number(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  char text[32];
  std::snprintf(text, sizeof text, "%.15g", value);  // 15: no 0.049280000000000004
  return text;
}

// A bucket edge, shortest: 0.0005, not 0.00050000000000000001.
std::string edge(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", seconds);
  return text;
}

void labels_text(std::string& out, const Labels& labels, std::string_view le) {
  if (labels.empty() && le.empty()) return;
  out += '{';
  bool first = true;
  for (const auto& [key, value] : labels) {
    if (!first) out += ',';
    first = false;
    out += key + "=\"" + escape_label_value(value) + "\"";
  }
  if (!le.empty()) {
    if (!first) out += ',';
    out += "le=\"";
    out += le;
    out += '"';
  }
  out += '}';
}

}  // namespace

std::string escape_label_value(std::string_view value) {
  std::string out;
  for (const char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"') {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

void family(std::string& out, std::string_view name, std::string_view type, std::string_view help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}

void sample(std::string& out, std::string_view name, const Labels& labels, double value) {
  out += name;
  labels_text(out, labels, {});
  out += ' ' + number(value) + '\n';
}

void single(std::string& out, std::string_view name, std::string_view type, std::string_view help,
            double value) {
  family(out, name, type, help);
  sample(out, name, {}, value);
}

void histogram_samples(std::string& out, std::string_view name, const Labels& labels,
                       std::span<const double> upper_edges_s, std::span<const std::uint64_t> counts,
                       double sum_s) {
  const std::string bucket = std::string(name) + "_bucket";
  std::uint64_t cumulative = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) {
    cumulative += counts[i];
    out += bucket;
    labels_text(out, labels, i < upper_edges_s.size() ? edge(upper_edges_s[i]) : "+Inf");
    out += ' ' + std::to_string(cumulative) + '\n';
  }
  out += std::string(name) + "_sum";
  labels_text(out, labels, {});
  out += ' ' + number(sum_s) + '\n';
  out += std::string(name) + "_count";
  labels_text(out, labels, {});
  out += ' ' + std::to_string(cumulative) + '\n';
}

}  // namespace ioct::view::prom
