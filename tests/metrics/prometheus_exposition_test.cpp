// The strict exposition reader itself: what it accepts, and that each rule it claims to check
// does refuse the text that breaks it (a reader that accepts everything proves nothing).
#include "prometheus_exposition.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace ioct::metrics_test {
namespace {

const std::string kGood =
    "# HELP a_total things\n# TYPE a_total counter\na_total 3\n"
    "# HELP g a gauge\n# TYPE g gauge\ng{x=\"q\\\"uote\\\\d\"} -1.5e-3\n"
    "# HELP h_seconds times\n# TYPE h_seconds histogram\n"
    "h_seconds_bucket{s=\"a\",le=\"0.5\"} 1\nh_seconds_bucket{s=\"a\",le=\"+Inf\"} 2\n"
    "h_seconds_sum{s=\"a\"} 0.7\nh_seconds_count{s=\"a\"} 2\n"
    "# HELP q_seconds quantiles\n# TYPE q_seconds summary\nq_seconds{quantile=\"0.5\"} 0.1\n"
    "q_seconds_sum 1\nq_seconds_count 4\n";

std::string refusal(const std::string& text) {
  try {
    (void)parse_exposition(text);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "accepted";
}

std::string with(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("no '" + from + "' in the text");
  return text.replace(at, from.size(), to);
}

TEST(PrometheusExposition, ReadsFamiliesSamplesAndEscapedLabels) {
  const Exposition e = parse_exposition(kGood);
  EXPECT_EQ(e.families.at("a_total").type, "counter");
  EXPECT_EQ(e.value("a_total"), 3.0);
  EXPECT_EQ(e.value("g", {{"x", "q\"uote\\d"}}), -1.5e-3);
  EXPECT_EQ(e.value("h_seconds_count", {{"s", "a"}}), 2.0);
  EXPECT_EQ(e.families.at("q_seconds").samples.size(), 3u);
}

TEST(PrometheusExposition, RefusesWhatAScraperCouldNotRelyOn) {
  EXPECT_NE(refusal(with(kGood, "# HELP a_total things\n", "")).find("without its HELP"),
            std::string::npos);
  EXPECT_NE(refusal("# HELP a x\na 1\n").find("before its family's TYPE"), std::string::npos);
  EXPECT_NE(refusal(with(kGood, "a_total 3", "a-total 3")).find("bad metric name"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "g{x=", "g{1x=")).find("bad label name"), std::string::npos);
  EXPECT_NE(refusal(with(kGood, "a_total 3", "a_total 3\na_total 4")).find("given twice"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "a_total 3", "b_total 3")).find("does not belong"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "le=\"+Inf\"} 2", "le=\"+Inf\"} 0")).find("not cumulative"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "le=\"+Inf\"} 2", "le=\"9\"} 2")).find("+Inf"), std::string::npos);
  EXPECT_NE(refusal(with(kGood, "h_seconds_count{s=\"a\"} 2", "h_seconds_count{s=\"a\"} 3"))
                .find("_count differs"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "h_seconds_sum{s=\"a\"} 0.7\n", "")).find("no _sum"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "a_total 3", "a_total three")).find("not a number"),
            std::string::npos);
  EXPECT_NE(refusal(with(kGood, "# TYPE g gauge", "# TYPE g meter")).find("unknown type"),
            std::string::npos);
  EXPECT_NE(refusal(kGood.substr(0, kGood.size() - 1)).find("final newline"), std::string::npos);
}

}  // namespace
}  // namespace ioct::metrics_test
