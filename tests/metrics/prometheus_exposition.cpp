#include "prometheus_exposition.hpp"

#include <cmath>
#include <cstdlib>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

namespace ioct::metrics_test {
namespace {

bool name_char(char c, bool first, bool colon_ok) {
  const bool letter = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_';
  if (letter || (colon_ok && c == ':')) return true;
  return !first && c >= '0' && c <= '9';
}

bool valid_name(const std::string& s, bool colon_ok) {
  if (s.empty()) return false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (!name_char(s[i], i == 0, colon_ok)) return false;
  }
  return true;
}

double parse_value(const std::string& text) {
  if (text == "NaN") return std::nan("");
  if (text == "+Inf") return INFINITY;
  if (text == "-Inf") return -INFINITY;
  if (text.empty()) throw std::runtime_error("no value");
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || std::isinf(v) || std::isnan(v)) {
    throw std::runtime_error("value '" + text + "' is not a number");
  }
  return v;
}

// name{a="x",b="y"} value
Sample parse_sample(const std::string& line) {
  Sample s;
  std::size_t i = 0;
  while (i < line.size() && line[i] != '{' && line[i] != ' ') ++i;
  s.name = line.substr(0, i);
  if (!valid_name(s.name, true)) throw std::runtime_error("bad metric name '" + s.name + "'");
  if (i < line.size() && line[i] == '{') {
    ++i;
    while (i < line.size() && line[i] != '}') {
      std::size_t eq = line.find('=', i);
      if (eq == std::string::npos) throw std::runtime_error("label without '='");
      const std::string key = line.substr(i, eq - i);
      if (!valid_name(key, false)) throw std::runtime_error("bad label name '" + key + "'");
      if (eq + 1 >= line.size() || line[eq + 1] != '"') {
        throw std::runtime_error("label " + key + ": value not quoted");
      }
      std::string value;
      std::size_t j = eq + 2;
      for (;; ++j) {
        if (j >= line.size()) throw std::runtime_error("label " + key + ": unterminated value");
        const char c = line[j];
        if (c == '"') break;
        if (c == '\\') {
          if (j + 1 >= line.size()) throw std::runtime_error("label " + key + ": bad escape");
          const char e = line[++j];
          if (e == '\\' || e == '"') {
            value += e;
          } else if (e == 'n') {
            value += '\n';
          } else {
            throw std::runtime_error("label " + key + ": bad escape \\" + std::string(1, e));
          }
        } else {
          value += c;
        }
      }
      if (!s.labels.emplace(key, value).second) {
        throw std::runtime_error("label " + key + " given twice");
      }
      i = j + 1;
      if (i < line.size() && line[i] == ',') ++i;
    }
    if (i >= line.size()) throw std::runtime_error("labels not closed");
    ++i;  // '}'
  }
  if (i >= line.size() || line[i] != ' ') throw std::runtime_error("no space before the value");
  const std::string rest = line.substr(i + 1);
  if (rest.find(' ') != std::string::npos) {
    throw std::runtime_error("timestamps or extra fields are not expected: '" + rest + "'");
  }
  s.value = parse_value(rest);
  return s;
}

std::string series_key(const Sample& s, bool without_le) {
  std::string key = s.name + "{";
  for (const auto& [k, v] : s.labels) {
    if (without_le && k == "le") continue;
    key += k + "=" + v + ",";
  }
  return key + "}";
}

void check_histogram(const Family& f) {
  // Per label set without le: the buckets in order, then the sum and the count.
  struct Series {
    std::vector<std::pair<double, double>> buckets;  // le, cumulative count
    bool has_sum = false;
    std::optional<double> count;
  };
  std::map<std::string, Series> series;
  for (const Sample& s : f.samples) {
    Sample base = s;
    base.name = f.name;
    const std::string key = series_key(base, true);
    if (s.name == f.name + "_bucket") {
      const auto le = s.labels.find("le");
      if (le == s.labels.end()) throw std::runtime_error(f.name + ": a bucket without le");
      series[key].buckets.emplace_back(parse_value(le->second), s.value);
    } else if (s.name == f.name + "_sum") {
      series[key].has_sum = true;
    } else if (s.name == f.name + "_count") {
      series[key].count = s.value;
    } else {
      throw std::runtime_error(f.name + ": sample " + s.name + " does not belong to a histogram");
    }
  }
  for (const auto& [key, s] : series) {
    if (s.buckets.empty()) throw std::runtime_error(key + ": no buckets");
    for (std::size_t i = 1; i < s.buckets.size(); ++i) {
      if (!(s.buckets[i].first > s.buckets[i - 1].first)) {
        throw std::runtime_error(key + ": bucket edges not ascending");
      }
      if (s.buckets[i].second < s.buckets[i - 1].second) {
        throw std::runtime_error(key + ": bucket counts not cumulative");
      }
    }
    if (!std::isinf(s.buckets.back().first)) {
      throw std::runtime_error(key + ": the last bucket is not le=\"+Inf\"");
    }
    if (!s.has_sum) throw std::runtime_error(key + ": no _sum");
    if (!s.count) throw std::runtime_error(key + ": no _count");
    if (*s.count != s.buckets.back().second) {
      throw std::runtime_error(key + ": _count differs from the +Inf bucket");
    }
  }
}

void check_family(const Family& f) {
  if (f.type == "histogram") return check_histogram(f);
  for (const Sample& s : f.samples) {
    const bool own = s.name == f.name;
    const bool part =
        f.type == "summary" && (s.name == f.name + "_sum" || s.name == f.name + "_count");
    if (!own && !part) {
      throw std::runtime_error("sample " + s.name + " does not belong to " + f.type + " " + f.name);
    }
    if (f.type == "counter" && s.value < 0) throw std::runtime_error(s.name + ": negative counter");
  }
}

}  // namespace

double Exposition::value(const std::string& name,
                         const std::map<std::string, std::string>& labels) const {
  for (const auto& [family_name, f] : families) {
    for (const Sample& s : f.samples) {
      if (s.name == name && s.labels == labels) return s.value;
    }
  }
  throw std::out_of_range("no sample " + name);
}

Exposition parse_exposition(const std::string& text) {
  Exposition e;
  Family* current = nullptr;
  std::string pending_help_name;
  std::string pending_help;
  std::set<std::string> series;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  try {
    if (!text.empty() && text.back() != '\n') throw std::runtime_error("no final newline");
    while (std::getline(in, line)) {
      ++number;
      if (line.empty()) throw std::runtime_error("empty line");
      if (line.rfind("# HELP ", 0) == 0) {
        const std::size_t space = line.find(' ', 7);
        pending_help_name = line.substr(7, space == std::string::npos ? space : space - 7);
        if (!valid_name(pending_help_name, true)) {
          throw std::runtime_error("bad name in HELP '" + pending_help_name + "'");
        }
        if (e.families.contains(pending_help_name)) {
          throw std::runtime_error("family " + pending_help_name + " announced twice");
        }
        pending_help = space == std::string::npos ? "" : line.substr(space + 1);
        current = nullptr;
        continue;
      }
      if (line.rfind("# TYPE ", 0) == 0) {
        std::istringstream words(line.substr(7));
        std::string name;
        std::string type;
        words >> name >> type;
        if (name != pending_help_name) {
          throw std::runtime_error("TYPE of " + name + " without its HELP just before");
        }
        static const std::set<std::string> types{"counter", "gauge", "histogram", "summary",
                                                 "untyped"};
        if (!types.contains(type)) throw std::runtime_error("unknown type '" + type + "'");
        current = &e.families[name];
        current->name = name;
        current->type = type;
        current->help = pending_help;
        pending_help_name.clear();
        continue;
      }
      if (line[0] == '#') throw std::runtime_error("a comment that is not HELP or TYPE");
      if (current == nullptr) throw std::runtime_error("a sample before its family's TYPE");
      const Sample s = parse_sample(line);
      if (!series.insert(series_key(s, false)).second) {
        throw std::runtime_error("series " + series_key(s, false) + " given twice");
      }
      current->samples.push_back(s);
    }
    if (!pending_help_name.empty()) throw std::runtime_error("HELP without TYPE at the end");
    for (const auto& [name, f] : e.families) {
      if (f.samples.empty()) throw std::runtime_error("family " + name + " has no samples");
      check_family(f);
    }
  } catch (const std::runtime_error& error) {
    throw std::runtime_error("line " + std::to_string(number) + ": " + error.what());
  }
  return e;
}

}  // namespace ioct::metrics_test
