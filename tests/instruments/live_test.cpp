// The detection in ioct-gpu's live stages: a forceps scene handed over group by group to
// VolumeStages with instruments enabled; the status line, the view socket's "instruments" answer
// and summary.json carry the tip where the simulator put it and its distances, and its frames the
// tip and the B-scan pair through it. CPU stages, and CUDA stages on a GPU machine (skipped
// without one) handed a host volume or, as the CUDA live pipeline does, a device one that the
// detection reads in place.
#include <gtest/gtest.h>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "decoded_jpeg.hpp"
#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "live_volumes.hpp"

#if IOCT_GPU_WITH_CUDA
#include "ioct/gpu/cuda/cuda_support.hpp"
#endif

namespace ioct::instruments_test {
namespace {

// Where the stages run, and where the live volume they are handed lies.
struct LivePlace {
  gpu::Backend backend = gpu::Backend::cpu;
  bool device_volume = false;  // the CUDA live pipeline's device volume, read in place
};

class LiveInstruments : public ::testing::TestWithParam<LivePlace> {
 protected:
  void SetUp() override {
    if (GetParam().backend == gpu::Backend::cuda) {
      if (const auto why = gpu::cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA: " << *why;
    }
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  const std::filesystem::path dir_ =
      std::filesystem::temp_directory_path() /
      ("ioct-instruments-live-" + std::to_string(static_cast<int>(GetParam().backend)) +
       (GetParam().device_volume ? "-device-" : "-") + std::to_string(::getpid()));
};

std::string place_name(const LivePlace& place) {
  if (place.backend == gpu::Backend::cpu) return "cpu";
  return place.device_volume ? "cuda_device_volume" : "cuda";
}

TEST_P(LiveInstruments, TheStatusTheViewSocketTheSummaryAndTheFramesCarryTheTip) {
  std::filesystem::create_directories(dir_);
  const SceneVolume scene = make_scene_volume(instrument_scenes()[0]);  // forceps approaching
  gpu::live::VolumeStagesConfig config;
  config.backend = GetParam().backend;
  config.cpu_threads = 2;
  config.render.view.output_width = 64;
  config.render.view.output_height = 48;
  config.sampling = scene.sampling;
  config.instruments.enabled = true;
  config.instruments.warn_rpe_um = 600.0;  // the tip is ~530 um above the RPE
  config.cpu_render_interval_s = 0.0;      // a frame for every pass on the CPU too
  config.frame_ring =
      "ioct-test-instruments-live-" + place_name(GetParam()) + "-" + std::to_string(::getpid());
  gpu::live::VolumeStages stages(config);
  EXPECT_EQ(stages.instruments().at("enabled"), true);
  shm::FrameRingReader frames = shm::FrameRingReader::attach(config.frame_ring);

#if IOCT_GPU_WITH_CUDA
  const gpu::cuda::BusTraffic before = gpu::cuda::bus_traffic();
#endif
  gpu::live::FakeLiveVolume live(GetParam().device_volume);
  live.volume = scene.volume.volume;
  for (std::uint32_t first = 0; first < live.volume.bscans(); first += 16) {
    live.written(first, 16);
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

  // The last frame carries the nearest tip of the findings and the B-scan pair through it, as
  // cut from the volume the detection read (on the device chain it is cut while the device
  // renders, on the CPU path as the frame is published).
  shm::Frame frame, last;
  while (frames.read_next(frame)) {
    if (frame.meta.tip_bscans_bytes > 0) last = frame;
  }
  const gpu::instruments::InstrumentTip* nearest = stages.findings().nearest_tip();
  ASSERT_NE(nearest, nullptr);
  ASSERT_GT(last.meta.tip_bscans_bytes, 0u) << "no frame carried the tip's B-scan pair";
  EXPECT_EQ(last.meta.instrument.state,
            static_cast<std::uint32_t>(shm::FrameInstrumentState::found));
  EXPECT_FLOAT_EQ(last.meta.instrument.tip_voxel[0], static_cast<float>(nearest->bscan));
  EXPECT_FLOAT_EQ(last.meta.instrument.tip_voxel[1], static_cast<float>(nearest->ascan));
  gpu::instruments::TipBscans expected;
  gpu::instruments::cut_tip_bscans(scene.volume.volume, *nearest, scene.sampling, expected);
  EXPECT_EQ(last.meta.tip_bscan_width, expected.width);
  EXPECT_EQ(last.meta.tip_bscan_height, expected.height);
  const gpu::live::DecodedJpeg pair = gpu::live::decode_jpeg(last.tip_bscans());
  ASSERT_EQ(pair.pixels.size(), expected.pixels.size());
  // Something to compare: 2 % of the cut brighter than the vitreous's speckle (u8 60); the
  // JPEG's loss (quality 90) well within 1.5 levels per px, a cut 120 um aside 2.3.
  constexpr unsigned char kTissue = 60;
  constexpr double kMaxMeanDifference = 1.5;
  const auto tissue = std::count_if(expected.pixels.begin(), expected.pixels.end(),
                                    [](unsigned char v) { return v > kTissue; });
  EXPECT_GT(static_cast<std::size_t>(tissue), expected.pixels.size() / 50)
      << "the pair cut here shows no tissue to compare";
  const double difference = gpu::live::mean_abs_difference(pair.pixels, expected.pixels);
  EXPECT_LT(difference, kMaxMeanDifference) << "mean |JPEG - cut| per px of the pair";
  std::printf("[ figures  ] the frame's tip pair: %u x %u px each, mean |JPEG - cut| %.3f\n",
              expected.width, expected.height, difference);

#if IOCT_GPU_WITH_CUDA
  if (GetParam().device_volume) {
    // The detection read the device volume in place: no B-scan crossed during the passes (the
    // files at the end bring the filtered volume back once, counted after finish()).
    const gpu::cuda::BusTraffic after = gpu::cuda::bus_traffic();
    EXPECT_EQ(after.volume_to_device - before.volume_to_device, 0u);
  }
#endif
}

TEST(LiveInstrumentsOff, NothingIsReportedWhenDisabled) {
  gpu::live::VolumeStagesConfig config;
  config.backend = gpu::Backend::cpu;
  gpu::live::VolumeStages stages(config);
  EXPECT_EQ(stages.instruments(), (nlohmann::json{{"enabled", false}}));
  EXPECT_EQ(stages.status().find("instruments"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Backends, LiveInstruments,
                         ::testing::Values(LivePlace{gpu::Backend::cpu, false},
                                           LivePlace{gpu::Backend::cuda, false},
                                           LivePlace{gpu::Backend::cuda, true}),
                         [](const ::testing::TestParamInfo<LivePlace>& param) {
                           return place_name(param.param);
                         });

}  // namespace
}  // namespace ioct::instruments_test
