// VolumeStages fed a volume group by group, faster than the stages work, so groups fold: after
// finish() the filtered volume must equal the whole volume filtered at once (nothing handed over
// is skipped), the surfaces cover the volume, and the files are written.
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "ioct/gpu/filters/volume_filter.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "live_volumes.hpp"

namespace ioct::gpu::live {
namespace {

class VolumeStagesTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    if (GetParam() == Backend::cuda) {
      if (const auto why = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA: " << *why;
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  // Per test and process: ctest runs the tests of this binary side by side.
  const std::filesystem::path dir_ = [] {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "-" + info->name();
    std::ranges::replace(name, '/', '-');
    const auto path = std::filesystem::temp_directory_path() /
                      ("ioct-live-" + name + "-" + std::to_string(::getpid()));
    std::filesystem::create_directories(path);
    return path;
  }();
};

TEST_P(VolumeStagesTest, FoldedGroupsEndAsTheWholeVolumeFilteredAndSegmented) {
  VolumeStagesConfig config;
  config.backend = GetParam();
  config.cpu_threads = 2;
  config.render.view.output_width = 160;
  config.render.view.output_height = 120;
  config.cpu_render_interval_s = 0.0;
  config.live_image = dir_ / "render.png";
  VolumeStages stages(config);

  FakeLiveVolume live;
  live.volume = layered_volume(32, 96, 256, 11);
  constexpr std::uint32_t kGroup = 4;
  for (std::uint32_t first = 0; first < live.volume.bscans(); first += kGroup) {
    stages.on_bscans(live, first, kGroup,
                     GroupStamp{});  // no waiting: later groups fold into one pass
  }
  // A second lap overwrites the first half, as the next volume does.
  const Volume second = layered_volume(32, 96, 256, 12);
  std::copy_n(second.pixels().data(), 16 * second.bscan_pixels(), live.volume.pixels().data());
  stages.on_bscans(live, 0, 16, GroupStamp{});

  const nlohmann::json summary = stages.finish(dir_);
  ASSERT_EQ(summary.at("problem"), "") << summary.dump(2);
  EXPECT_EQ(summary.at("groups").get<std::uint64_t>(), 9u);
  EXPECT_EQ(
      summary.at("groups").get<std::uint64_t>(),
      summary.at("passes").get<std::uint64_t>() + summary.at("groups_folded").get<std::uint64_t>());

  Volume expected;
  filters::make_volume_filter(Backend::cpu, config.filter)->filter_volume(live.volume, expected);
  ASSERT_EQ(stages.filtered().bscans(), expected.bscans());
  EXPECT_TRUE(std::ranges::equal(stages.filtered().pixels(), expected.pixels()))
      << "every B-scan handed over was filtered, with its neighbours' halo, as of its last copy";

  EXPECT_EQ(stages.surfaces().bscans, 32u);
  EXPECT_EQ(summary.at("surfaces").at("bscans").get<std::uint32_t>(), 32u);
  for (const char* file : {"surfaces", "bscan_overlay", "render", "layer-aware", "la-mip"}) {
    const std::filesystem::path path = summary.at("files").at(file).get<std::string>();
    EXPECT_TRUE(std::filesystem::exists(path)) << path;
  }
}

TEST(VolumeStagesConfig, BadConfigIsRefusedNamingTheKey) {
  VolumeStagesConfig config;
  config.cpu_render_interval_s = -1.0;
  try {
    VolumeStages stages(config);
    FAIL() << "accepted a negative render interval";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("stages.cpu_render_interval"), std::string::npos)
        << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, VolumeStagesTest, ::testing::Values(Backend::cpu, Backend::cuda),
                         [](const auto& param_info) {
                           return std::string(to_string(param_info.param));
                         });

}  // namespace
}  // namespace ioct::gpu::live
