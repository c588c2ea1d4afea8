// ioct-view's writers of the other processes' figures, on statuses made here: what a peer that is
// gone, or reports a figure of the wrong type, turns into (the status comes from another process
// and is not trusted), and that what they write reads back strictly.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include <cmath>
#include <limits>

#include "gpu_metrics.hpp"
#include "instrument_metrics.hpp"
#include "prometheus_exposition.hpp"
#include "rt_metrics.hpp"

namespace ioct::metrics_test {
namespace {

Exposition rt_text(const nlohmann::json& status) {
  std::string out;
  view::append_rt_metrics(out, status);
  return parse_exposition(out);
}

Exposition gpu_text(const view::FollowerSnapshot& f) {
  std::string out;
  view::append_gpu_metrics(out, f);
  return parse_exposition(out);
}

TEST(ViewMetrics, AnUnreachableRtShowsOnlyThatItIsDown) {
  const Exposition e = rt_text(nullptr);
  EXPECT_EQ(e.families.size(), 1u);
  EXPECT_EQ(e.value("ioct_rt_up"), 0.0);
}

TEST(ViewMetrics, RtFiguresOfTheWrongTypeAreLeftOutNotShownAsZero) {
  nlohmann::json status = {{"acquisition",
                            {{"groups_published", "12"},
                             {"deadline_misses", 3},
                             {"replay", true},
                             {"missed_sweeps", {}}}},
                           {"wake_latency", {{"counts", {1, "2", 3}}, {"total_ns", 100}}},
                           {"readers",
                            {{{"label", "gpu \"main\"\nline"},
                              {"pid", 42},
                              {"alive", true},
                              {"consumed", 7},
                              {"dropped_lapped", 1},
                              {"dropped_behind", 0}},
                             {{"label", "no pid"}, {"alive", false}, {"consumed", 9}}}}};
  const Exposition e = rt_text(status);
  EXPECT_EQ(e.value("ioct_rt_up"), 1.0);
  EXPECT_FALSE(e.has("ioct_rt_groups_published_total")) << "a string is not a count";
  EXPECT_FALSE(e.has("ioct_rt_missed_sweeps_total"));
  EXPECT_EQ(e.value("ioct_rt_deadline_misses_total"), 3.0);
  EXPECT_EQ(e.value("ioct_rt_replay"), 1.0);
  EXPECT_FALSE(e.has("ioct_rt_wake_latency_seconds")) << "a bucket that is not a count";
  EXPECT_EQ(e.value("ioct_rt_readers"), 1.0);
  // The label as the reader registered it, escaped on the way and read back whole.
  EXPECT_EQ(e.value("ioct_rt_reader_groups_consumed_total",
                    {{"reader", "gpu \"main\"\nline"}, {"pid", "42"}}),
            7.0);
  EXPECT_EQ(e.value("ioct_rt_reader_groups_dropped_total",
                    {{"reader", "gpu \"main\"\nline"}, {"pid", "42"}, {"cause", "lapped"}}),
            1.0);
  EXPECT_EQ(e.families.at("ioct_rt_reader_groups_consumed_total").samples.size(), 1u)
      << "a reader without a pid is not shown";
}

TEST(ViewMetrics, TheWakeUpHistogramHasEveryBucketCumulatively) {
  // Bucket i below 2^i us; the last one everything above.
  const nlohmann::json status = {
      {"wake_latency", {{"counts", {0, 2, 0, 5}}, {"total_ns", 123'456}}}};
  const Exposition e = rt_text(status);
  EXPECT_EQ(e.value("ioct_rt_wake_latency_seconds_bucket", {{"le", "1e-06"}}), 0.0);
  EXPECT_EQ(e.value("ioct_rt_wake_latency_seconds_bucket", {{"le", "2e-06"}}), 2.0);
  EXPECT_EQ(e.value("ioct_rt_wake_latency_seconds_bucket", {{"le", "4e-06"}}), 2.0);
  EXPECT_EQ(e.value("ioct_rt_wake_latency_seconds_bucket", {{"le", "+Inf"}}), 7.0);
  EXPECT_EQ(e.value("ioct_rt_wake_latency_seconds_count"), 7.0);
  EXPECT_DOUBLE_EQ(e.value("ioct_rt_wake_latency_seconds_sum"), 123'456e-9);
}

TEST(ViewMetrics, ASilentGpuShowsNoneOfItsLastFigures) {
  view::FollowerSnapshot f;
  f.attached = true;
  f.writer_responding = false;  // attached, but the writer died or stopped beating
  f.status.groups_consumed = 99;
  f.status.filter.record(1'000'000);
  const Exposition e = gpu_text(f);
  EXPECT_EQ(e.families.size(), 1u);
  EXPECT_EQ(e.value("ioct_gpu_up"), 0.0);
}

TEST(ViewMetrics, TheTipsDistancesAreServedOnlyWhenKnownAndWhileTheGpuIsUp) {
  shm::FrameInstrument in{};
  const auto text = [&](bool up) {
    std::string out;
    view::write_instrument_metrics(in, up, out);
    return parse_exposition(out);
  };
  EXPECT_TRUE(text(true).families.empty()) << "detection off: nothing";
  in.state = static_cast<std::uint32_t>(shm::FrameInstrumentState::none);
  EXPECT_EQ(text(true).value("ioct_instrument_found"), 0.0);
  EXPECT_EQ(text(true).families.size(), 1u);

  in.state = static_cast<std::uint32_t>(shm::FrameInstrumentState::found);
  in.distance_source = static_cast<std::uint32_t>(shm::FrameDistanceSource::inferred);
  in.warning = 1;
  in.to_rpe_um = 80.0f;
  in.to_ilm_um = -12.5f;
  const Exposition e = text(true);
  EXPECT_EQ(e.value("ioct_instrument_found"), 1.0);
  EXPECT_EQ(e.value("ioct_instrument_warning"), 1.0);
  EXPECT_EQ(e.value("ioct_instrument_distance_inferred"), 1.0);
  EXPECT_NEAR(e.value("ioct_instrument_tip_to_rpe_meters"), 80e-6, 1e-12);
  EXPECT_NEAR(e.value("ioct_instrument_tip_to_ilm_meters"), -12.5e-6, 1e-12);

  // No surface near the tip: the distances are left out, not 0 (0 would read "touching").
  in.to_rpe_um = std::numeric_limits<float>::quiet_NaN();
  in.to_ilm_um = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(text(true).has("ioct_instrument_tip_to_rpe_meters"));
  EXPECT_FALSE(text(true).has("ioct_instrument_tip_to_ilm_meters"));
  // A pipeline that stopped: its last tip is not served as current.
  in.to_rpe_um = 80.0f;
  EXPECT_TRUE(text(false).families.empty());
}

TEST(ViewMetrics, GpuStageTimesBecomeOneHistogramPerStageAndMemoryOnlyWhenKnown) {
  view::FollowerSnapshot f;
  f.attached = true;
  f.writer_responding = true;
  f.status.groups_consumed = 99;
  f.status.filter.record(1'000'000);   // 1 ms: on the 1 ms edge (inclusive)
  f.status.filter.record(30'000'000);  // 30 ms
  Exposition e = gpu_text(f);
  EXPECT_EQ(e.value("ioct_gpu_up"), 1.0);
  EXPECT_EQ(e.value("ioct_gpu_groups_consumed_total"), 99.0);
  EXPECT_EQ(e.value("ioct_gpu_stage_seconds_bucket", {{"stage", "filter"}, {"le", "0.0005"}}), 0.0);
  EXPECT_EQ(e.value("ioct_gpu_stage_seconds_bucket", {{"stage", "filter"}, {"le", "0.001"}}), 1.0);
  EXPECT_EQ(e.value("ioct_gpu_stage_seconds_bucket", {{"stage", "filter"}, {"le", "0.02"}}), 1.0);
  EXPECT_EQ(e.value("ioct_gpu_stage_seconds_bucket", {{"stage", "filter"}, {"le", "0.05"}}), 2.0);
  EXPECT_DOUBLE_EQ(e.value("ioct_gpu_stage_seconds_sum", {{"stage", "filter"}}), 0.031);
  EXPECT_EQ(e.value("ioct_gpu_stage_seconds_count", {{"stage", "render"}}), 0.0);
  EXPECT_FALSE(e.has("ioct_gpu_device_memory_used_bytes")) << "CPU: absent, not 0";

  f.status.device_memory_known = 1;
  f.status.device_memory_used_bytes = 3ull << 30;
  f.status.device_memory_total_bytes = 80ull << 30;
  e = gpu_text(f);
  EXPECT_EQ(e.value("ioct_gpu_device_memory_used_bytes"), static_cast<double>(3ull << 30));
  EXPECT_EQ(e.value("ioct_gpu_device_memory_total_bytes"), static_cast<double>(80ull << 30));
}

}  // namespace
}  // namespace ioct::metrics_test
