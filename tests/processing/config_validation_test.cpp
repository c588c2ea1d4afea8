// Every config error names the key, the value and what would be accepted.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <optional>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/ingest/live_processor.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/volume/projections.hpp"

namespace ioct::gpu {
namespace {

// Runs `action`, which must throw ConfigError for `key`, with every fragment in its message.
void expect_config_error(const std::function<void()>& action, const std::string& key,
                         std::initializer_list<std::string> fragments) {
  try {
    action();
    FAIL() << "no error for " << key;
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(key + " = ", 0), 0u) << message;
    for (const std::string& fragment : fragments) {
      EXPECT_NE(message.find(fragment), std::string::npos) << message << " lacks " << fragment;
    }
  }
}

TEST(ConfigValidation, DbRange) {
  expect_config_error(
      [] {
        DbScaleConfig{-300.0, 40.0}.validate();
      },
      "db_min", {"-300", "[-200, 300]"});
  expect_config_error([] { DbScaleConfig{0.0, 1e9}.validate(); }, "db_max", {"1e+09"});
  expect_config_error(
      [] {
        DbScaleConfig{20.0, 20.5}.validate();
      },
      "db_max", {"20.5", "db_min (20)"});
  expect_config_error([] { DbScaleConfig{std::nan(""), 40.0}.validate(); }, "db_min", {"nan"});
  EXPECT_NO_THROW(DbScaleConfig{}.validate());
}

TEST(ConfigValidation, ProcessorThreads) {
  OctProcessorConfig config;
  config.threads = 0;
  expect_config_error([&] { config.validate(); }, "threads", {"0", "[1, 16]"});
  config.threads = 17;
  expect_config_error([&] { config.validate(); }, "threads", {"17"});
  config.threads = 2;
  config.scale.db_max = -10.0;
  expect_config_error([&] { config.validate(); }, "db_max", {"-10"});
}

TEST(ConfigValidation, NamedChoices) {
  expect_config_error([] { parse_backend("gpu"); }, "backend", {"'gpu'", "cpu, cuda or auto"});
  expect_config_error([] { parse_window_kind("hamming"); }, "window", {"'hamming'", "hann"});
  expect_config_error([] { parse_fft_rigor("exhaustive"); }, "fft_rigor", {"patient"});
  expect_config_error([] { parse_background_mode("group-mean"); }, "background",
                      {"rolling or none"});
  expect_config_error([] { parse_interpolation("spline"); }, "resampling",
                      {"'spline'", "none, linear or cubic"});
  expect_config_error([] { parse_enface_projection("sum"); }, "enface", {"mean or max"});
  EXPECT_EQ(parse_backend("cuda"), Backend::cuda);
  EXPECT_EQ(parse_backend("auto"), Backend::automatic);
  EXPECT_EQ(parse_background_mode("rolling"), BackgroundMode::rolling);
  EXPECT_EQ(parse_interpolation("cubic"), Interpolation::cubic);
  EXPECT_EQ(parse_window_kind("rectangular"), WindowKind::rectangular);
  EXPECT_EQ(parse_fft_rigor("patient"), FftRigor::patient);
  EXPECT_EQ(parse_background_mode("none"), BackgroundMode::none);
  EXPECT_EQ(parse_enface_projection("max"), EnfaceProjection::max);
}

TEST(ConfigValidation, LiveConfig) {
  const auto with = [](const std::function<void(LiveConfig&)>& change) {
    LiveConfig config;
    change(config);
    return [config] { config.validate(); };
  };
  expect_config_error(with([](LiveConfig& c) { c.wait_s = -1.0; }), "wait", {"-1"});
  expect_config_error(with([](LiveConfig& c) { c.run_s = -0.5; }), "seconds", {"-0.5"});
  expect_config_error(with([](LiveConfig& c) { c.status_interval_s = -2.0; }), "status_interval",
                      {"-2"});
  expect_config_error(with([](LiveConfig& c) { c.ring_name = "a/b"; }), "ring", {"'a/b'"});
  expect_config_error(with([](LiveConfig& c) { c.out_dir.clear(); }), "out", {});
  expect_config_error(with([](LiveConfig& c) { c.label = std::string(40, 'x'); }), "label",
                      {"31 characters"});
  expect_config_error(with([](LiveConfig& c) { c.processing.threads = 99; }), "threads", {"99"});
  EXPECT_NO_THROW(LiveConfig{}.validate());
  LiveConfig negative_wait;
  negative_wait.wait_s = -1.0;
  EXPECT_THROW(LiveProcessor{negative_wait}, ConfigError);
}

TEST(ConfigValidation, CudaBackendRunsOrIsAClearError) {
  const std::optional<std::string> reason = cuda_unavailable_reason();
  if (!IOCT_GPU_WITH_CUDA) {
    ASSERT_TRUE(reason.has_value());
    EXPECT_NE(reason->find("built without CUDA"), std::string::npos) << *reason;
  }
  std::string warning;
  if (reason) {
    try {
      (void)make_oct_processor(Backend::cuda, OctProcessorConfig{});
      FAIL() << "a CUDA processor was made although " << *reason;
    } catch (const BackendUnavailable& e) {
      EXPECT_NE(std::string(e.what()).find(*reason), std::string::npos) << e.what();
    }
    EXPECT_EQ(resolve_backend(Backend::automatic, &warning), Backend::cpu);
    EXPECT_NE(warning.find(*reason), std::string::npos) << warning;
    EXPECT_EQ(make_oct_processor(Backend::automatic, OctProcessorConfig{})->backend_name(), "cpu");
  } else {
    EXPECT_EQ(make_oct_processor(Backend::cuda, OctProcessorConfig{})->backend_name(), "cuda");
    EXPECT_EQ(resolve_backend(Backend::automatic, &warning), Backend::cuda);
    EXPECT_TRUE(warning.empty()) << warning;
  }
  EXPECT_EQ(resolve_backend(Backend::cpu, &warning), Backend::cpu);
  EXPECT_EQ(make_oct_processor(Backend::cpu, OctProcessorConfig{})->backend_name(), "cpu");
}

TEST(ConfigValidation, ProcessingStages) {
  OctProcessorConfig config;
  config.background.groups = 0;
  expect_config_error([&] { config.validate(); }, "background_groups", {"0", "[1, 64]"});
  config = {};
  config.repeats_per_position = 17;
  expect_config_error([&] { config.validate(); }, "repeats_per_position", {"17", "[1, 16]"});
  config = {};
  config.dispersion.c2 = std::nan("");
  expect_config_error([&] { config.validate(); }, "dispersion_c2", {"nan"});
  config = {};
  config.dispersion.c3 = 2e4;
  expect_config_error([&] { config.validate(); }, "dispersion_c3", {"20000"});
  // repeats must divide the group and the volume
  config = {};
  config.repeats_per_position = 3;
  shm::RingGeometry geometry;  // 16 per group, 128 per volume
  expect_config_error([&] { config.validate_for(geometry); }, "repeats_per_position",
                      {"3", "bscans_per_group (16)", "bscans_per_volume (128)"});
  config.repeats_per_position = 4;
  EXPECT_NO_THROW(config.validate_for(geometry));
}

}  // namespace
}  // namespace ioct::gpu
