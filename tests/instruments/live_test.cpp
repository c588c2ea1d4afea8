// The detection in ioct-gpu's live stages: a forceps scene handed over group by group to
// VolumeStages with instruments enabled; the status line, the view socket's "instruments" answer
// and summary.json carry the tip where the simulator put it and its distances. CPU stages, and
// CUDA stages on a GPU machine (skipped without one).
#include <gtest/gtest.h>

#include <unistd.h>
#include <filesystem>
#include <string>

#include "instrument_scenes.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "live_volumes.hpp"

namespace ioct::instruments_test {
namespace {

class LiveInstruments : public ::testing::TestWithParam<gpu::Backend> {
 protected:
  void SetUp() override {
    if (GetParam() == gpu::Backend::cuda) {
      if (const auto why = gpu::cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA: " << *why;
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  const std::filesystem::path dir_ =
      std::filesystem::temp_directory_path() /
      ("ioct-instruments-live-" + std::to_string(static_cast<int>(GetParam())) + "-" +
       std::to_string(::getpid()));
};

TEST_P(LiveInstruments, TheStatusTheViewSocketAndTheSummaryCarryTheTip) {
  std::filesystem::create_directories(dir_);
  const SceneVolume scene = make_scene_volume(instrument_scenes()[0]);  // forceps approaching
  gpu::live::VolumeStagesConfig config;
  config.backend = GetParam();
  config.cpu_threads = 2;
  config.render.view.output_width = 64;
  config.render.view.output_height = 48;
  config.sampling = scene.sampling;
  config.instruments.enabled = true;
  config.instruments.warn_rpe_um = 600.0;  // the tip is ~530 um above the RPE
  gpu::live::VolumeStages stages(config);
  EXPECT_EQ(stages.instruments().at("enabled"), true);

  gpu::live::FakeLiveVolume live;
  live.volume = scene.volume.volume;
  for (std::uint32_t first = 0; first < live.volume.bscans(); first += 16) {
    stages.on_bscans(live, first, 16, gpu::GroupStamp{});
  }
  const nlohmann::json summary = stages.finish(dir_);
  ASSERT_EQ(summary.at("problem"), "") << summary.dump(2);
  const nlohmann::json& found = summary.at("instruments");
  ASSERT_EQ(found.at("tips").size(), 1u) << found.dump(2);
  const nlohmann::json& tip = found.at("tips").at(0);
  EXPECT_NEAR(tip.at("voxel").at(0).get<double>(), scene.tip.bscan, 3.0);
  EXPECT_NEAR(tip.at("voxel").at(1).get<double>(), scene.tip.ascan, 3.0);
  EXPECT_NEAR(tip.at("voxel").at(2).get<double>(), scene.tip.depth_px, 3.0);
  EXPECT_NEAR(tip.at("to_rpe_um").get<double>(), scene.to_rpe_um, 30.0);
  EXPECT_EQ(tip.at("distance"), "inferred");
  EXPECT_EQ(found.at("warning"), true);
  EXPECT_TRUE(summary.contains("instruments_ms"));
  EXPECT_NE(summary.at("backends").get<std::string>().find("instruments"), std::string::npos);

  const nlohmann::json answer = stages.instruments();
  EXPECT_EQ(answer.at("enabled"), true);
  EXPECT_EQ(answer.at("tips"), found.at("tips"));
  const std::string status = stages.status();
  EXPECT_NE(status.find("instruments: tip"), std::string::npos) << status;
  EXPECT_NE(status.find("WARNING"), std::string::npos) << status;
}

TEST(LiveInstrumentsOff, NothingIsReportedWhenDisabled) {
  gpu::live::VolumeStagesConfig config;
  config.backend = gpu::Backend::cpu;
  gpu::live::VolumeStages stages(config);
  EXPECT_EQ(stages.instruments(), (nlohmann::json{{"enabled", false}}));
  EXPECT_EQ(stages.status().find("instruments"), std::string::npos);
}

std::string backend_name(const ::testing::TestParamInfo<gpu::Backend>& param) {
  return param.param == gpu::Backend::cpu ? "cpu" : "cuda";
}

INSTANTIATE_TEST_SUITE_P(Backends, LiveInstruments,
                         ::testing::Values(gpu::Backend::cpu, gpu::Backend::cuda), backend_name);

}  // namespace
}  // namespace ioct::instruments_test
