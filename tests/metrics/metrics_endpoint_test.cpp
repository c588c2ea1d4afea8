// /metrics on the simulated appliance: ioct-rt on the simulator, ioct-gpu on the CPU (or CUDA
// where there is one) and ioct-view, as processes. The text must be a strict Prometheus
// exposition, both processes' figures must move between two scrapes, and once ioct-gpu and then
// ioct-rt are gone none of their figures may be shown as if they were live.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <functional>
#include <string>
#include <thread>

#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/view_test/live_appliance.hpp"
#include "prometheus_exposition.hpp"

namespace ioct::metrics_test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const char* const kStages[] = {"ingest", "filter", "segmentation", "render", "publish"};

Exposition scrape(const view_test::LiveAppliance& app) {
  const view_test::HttpReply reply = app.http("GET", "/metrics");
  if (reply.status != 200) {
    throw std::runtime_error("GET /metrics: " + std::to_string(reply.status) + " " + reply.problem);
  }
  try {
    return parse_exposition(reply.body);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string("/metrics is not a valid exposition: ") + e.what() + "\n" +
                             reply.body);
  }
}

double or_zero(const Exposition& e, const std::string& name,
               const std::map<std::string, std::string>& labels = {}) {
  try {
    return e.value(name, labels);
  } catch (const std::out_of_range&) {
    return 0.0;
  }
}

// Scrapes until `done` holds or `timeout` passes; returns the last scrape.
Exposition scrape_until(const view_test::LiveAppliance& app, std::chrono::seconds timeout,
                        const std::function<bool(const Exposition&)>& done) {
  const auto deadline = Clock::now() + timeout;
  Exposition e = scrape(app);
  while (!done(e) && Clock::now() < deadline) {
    std::this_thread::sleep_for(200ms);
    e = scrape(app);
  }
  return e;
}

std::size_t families_with_prefix(const Exposition& e, const std::string& prefix,
                                 const std::string& except) {
  std::size_t n = 0;
  for (const auto& [name, family] : e.families) {
    if (name.rfind(prefix, 0) == 0 && name != except) ++n;
  }
  return n;
}

TEST(MetricsEndpoint, FiguresMoveParseStrictlyAndStopWithTheirProcess) {
  view_test::ApplianceOptions options;
  options.tag = "metrics";
  view_test::LiveAppliance app(options);
  app.start_all();

  // Both processes up and every stage timed at least once (the CPU renders every 2 s).
  const auto all_stages_timed = [](const Exposition& e) {
    if (or_zero(e, "ioct_gpu_up") != 1 || or_zero(e, "ioct_rt_up") != 1) return false;
    for (const char* stage : kStages) {
      if (or_zero(e, "ioct_gpu_stage_seconds_count", {{"stage", stage}}) == 0) return false;
    }
    return true;
  };
  const Exposition first = scrape_until(app, 60s, all_stages_timed);
  ASSERT_TRUE(all_stages_timed(first)) << app.logs();

  // The families a dashboard relies on, with their types; counters end in _total.
  const std::pair<const char*, const char*> expected[] = {
      {"ioct_rt_groups_published_total", "counter"},
      {"ioct_rt_deadline_misses_total", "counter"},
      {"ioct_rt_simulator_late_groups_total", "counter"},
      {"ioct_rt_wake_latency_seconds", "histogram"},
      {"ioct_rt_readers", "gauge"},
      {"ioct_rt_reader_groups_consumed_total", "counter"},
      {"ioct_rt_replay", "gauge"},
      {"ioct_gpu_groups_consumed_total", "counter"},
      {"ioct_gpu_groups_dropped_total", "counter"},
      {"ioct_gpu_stage_seconds", "histogram"},
      {"ioct_gpu_published_to_processed_seconds", "histogram"},
      {"ioct_gpu_published_to_rendered_seconds", "histogram"},
      {"ioct_view_viewers", "gauge"},
      {"ioct_view_published_to_sent_seconds", "summary"}};
  for (const auto& [name, type] : expected) {
    ASSERT_TRUE(first.has(name)) << name << " missing";
    EXPECT_EQ(first.families.at(name).type, type) << name;
  }
  for (const auto& [name, family] : first.families) {
    if (family.type == "counter") {
      EXPECT_TRUE(name.ends_with("_total")) << name;
    }
  }
  EXPECT_EQ(first.value("ioct_rt_replay"), 0.0) << "the simulator, not a recording";
  EXPECT_EQ(first.value("ioct_rt_simulated"), 1.0);
  EXPECT_GE(first.value("ioct_rt_readers"), 1.0) << "ioct-gpu reads the ring";
  // ioct-gpu runs with --backend auto: CUDA where this build and machine have it.
  if (const auto no_cuda = gpu::cuda_unavailable_reason()) {
    EXPECT_FALSE(first.has("ioct_gpu_device_memory_used_bytes"))
        << "the CPU backend (" << *no_cuda << ") has no device memory: absent, not 0";
    EXPECT_FALSE(first.has("ioct_gpu_device_memory_total_bytes"));
  } else {
    ASSERT_TRUE(first.has("ioct_gpu_device_memory_total_bytes")) << "the CUDA backend's memory";
    EXPECT_GT(first.value("ioct_gpu_device_memory_used_bytes"), 0.0);
    EXPECT_LE(first.value("ioct_gpu_device_memory_used_bytes"),
              first.value("ioct_gpu_device_memory_total_bytes"));
  }

  // The figures move: more groups published and consumed, every stage timed again.
  const auto moved = [&](const Exposition& e) {
    if (e.value("ioct_rt_groups_published_total") <=
            first.value("ioct_rt_groups_published_total") ||
        or_zero(e, "ioct_gpu_groups_consumed_total") <=
            first.value("ioct_gpu_groups_consumed_total") ||
        or_zero(e, "ioct_rt_wake_latency_seconds_count") <=
            first.value("ioct_rt_wake_latency_seconds_count") ||
        or_zero(e, "ioct_gpu_published_to_processed_seconds_count") <=
            first.value("ioct_gpu_published_to_processed_seconds_count")) {
      return false;
    }
    for (const char* stage : kStages) {
      if (or_zero(e, "ioct_gpu_stage_seconds_count", {{"stage", stage}}) <=
          first.value("ioct_gpu_stage_seconds_count", {{"stage", stage}})) {
        return false;
      }
    }
    return true;
  };
  const Exposition second = scrape_until(app, 60s, moved);
  EXPECT_TRUE(moved(second)) << app.logs();
  std::printf("[ figures  ] published %.0f -> %.0f, consumed %.0f -> %.0f, ingest count %.0f\n",
              first.value("ioct_rt_groups_published_total"),
              second.value("ioct_rt_groups_published_total"),
              first.value("ioct_gpu_groups_consumed_total"),
              or_zero(second, "ioct_gpu_groups_consumed_total"),
              or_zero(second, "ioct_gpu_stage_seconds_count", {{"stage", "ingest"}}));

  // ioct-gpu killed (no orderly close of its frame ring): ioct_gpu_up 0 and nothing else of it.
  app.gpu().signal(SIGKILL);
  const Exposition gpu_gone =
      scrape_until(app, 20s, [](const Exposition& e) { return e.value("ioct_gpu_up") == 0; });
  EXPECT_EQ(gpu_gone.value("ioct_gpu_up"), 0.0);
  EXPECT_EQ(families_with_prefix(gpu_gone, "ioct_gpu_", "ioct_gpu_up"), 0u)
      << "a stopped ioct-gpu's figures are not shown";
  EXPECT_EQ(gpu_gone.value("ioct_rt_up"), 1.0) << "ioct-rt still runs";

  // ioct-rt stopped: the same for its figures.
  app.rt().stop();
  const Exposition rt_gone =
      scrape_until(app, 20s, [](const Exposition& e) { return e.value("ioct_rt_up") == 0; });
  EXPECT_EQ(rt_gone.value("ioct_rt_up"), 0.0);
  EXPECT_EQ(families_with_prefix(rt_gone, "ioct_rt_", "ioct_rt_up"), 0u)
      << "a stopped ioct-rt's figures are not shown";
  if (HasFailure()) app.keep_folder();
}

}  // namespace
}  // namespace ioct::metrics_test
