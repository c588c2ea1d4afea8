// The live stages with the live volume on the device (as the CUDA live pipeline hands it over)
// against the CPU reference fed the same groups in the same passes: the filtered volume and the
// surfaces equal, the live frame within the renderers' tolerance (docs/rendering.md), through
// single groups, folded groups, a second lap and a geometry change; and no pass copies volume
// bytes between host and device. In a layer-aware mode (the renderer's own per-B-scan median,
// render_filter.hpp) the same, and after live changes of mode the frames too, with no volume
// bytes crossing for the change either. GPU only: skipped, saying why, without one.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ioct/gpu/live_stages/volume_stages.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "ioct/test_support/eventually.hpp"
#include "layered_volume.hpp"

#include "live_volumes.hpp"

#if IOCT_GPU_WITH_CUDA
#include "ioct/gpu/cuda/cuda_support.hpp"
#endif
#include "pass_gate.hpp"

namespace ioct::gpu::live {
namespace {

struct StagesRun {
  Volume filtered;
  segmentation::Surfaces surfaces;
  render::RgbaImage frame;
  std::vector<render::RgbaImage> switched;  // the shared view after each change of mode
  nlohmann::json summary;
  std::uint64_t passes = 0, folded_passes = 0;
  // With a frame ring: the B-scan picture (JPEG) of the last frame written, and its index.
  std::vector<std::byte> last_bscan_jpeg;
  std::uint32_t last_bscan_index = 0;
  // With instrument detection: the stages' host copy of the surfaces as the last pass left it
  // (before finish() reads everything back).
  segmentation::Surfaces surfaces_after_last_pass;
#if IOCT_GPU_WITH_CUDA
  cuda::BusTraffic traffic;         // during the passes
  cuda::BusTraffic switch_traffic;  // during the changes of mode and their frames
#endif
};

#if IOCT_GPU_WITH_CUDA
cuda::BusTraffic traffic_since(const cuda::BusTraffic& before) {
  const cuda::BusTraffic after = cuda::bus_traffic();
  cuda::BusTraffic t;
  t.volume_to_device = after.volume_to_device - before.volume_to_device;
  t.volume_to_host = after.volume_to_host - before.volume_to_host;
  t.other_to_device = after.other_to_device - before.other_to_device;
  t.other_to_host = after.other_to_host - before.other_to_host;
  return t;
}
#endif

// The same hand-overs for every backend: single groups, folded groups, a second lap over the
// first half, then a volume of other dimensions group by group, the live view in `mode`; then the
// live view's mode changed to each of `switches` in turn, with no new group, and its frame taken.
StagesRun run_stages(Backend backend, bool device_source, const std::filesystem::path& dir,
                     render::RenderMode mode = render::RenderMode::enhanced,
                     const std::vector<std::string>& switches = {},
                     const std::string& frame_ring = {}, bool instruments = false) {
  PassGate gate;
  const VolumeStages* running = nullptr;
  segmentation::Surfaces after_last_pass;
  VolumeStagesConfig config;
  config.backend = backend;
  config.cpu_threads = 2;
  config.render.view.output_width = 160;
  config.render.view.output_height = 120;
  config.render.view.rotation_deg_per_s = 0.0;  // the same view whenever it is rendered
  config.cpu_render_interval_s = 0.0;
  config.render.mode = mode;
  config.final_modes = {};
  // On the stages' thread, after the pass (and its detection): its host copy is read there.
  config.on_pass = [&gate, &running, &after_last_pass, instruments](const StagesPass& pass) {
    if (instruments && running != nullptr) after_last_pass = running->surfaces();
    // When the tips were found: after the segmentation (their distances need its surfaces); on
    // the device chain while the device works on the pass, so before the pass's end, which the
    // frame waits for.
    if (instruments) {
      EXPECT_GE(pass.detected_ns, pass.segmented_ns);
      if (pass.on_device) {
        EXPECT_LE(pass.detected_ns, pass.rendered_ns);
      }
    } else {
      EXPECT_EQ(pass.detected_ns, 0u);
    }
    gate.on_pass(pass);
  };
  config.frame_ring = frame_ring;
  config.instruments.enabled = instruments;
  VolumeStages stages(config);
  running = &stages;
  std::optional<shm::FrameRingReader> frames;
  if (!frame_ring.empty()) frames.emplace(shm::FrameRingReader::attach(frame_ring));

  // The device chain exists before the first hand-over: B-scans that come earlier wait on the
  // host and are uploaded (a slow start, e.g. under a sanitizer, would count them as volume bytes).
  EXPECT_TRUE(test_support::eventually([&] { return !stages.backends().empty(); },
                                       std::chrono::seconds(60)))
      << "the stages made no backends: " << stages.status();

  FakeLiveVolume live(device_source);
  std::uint64_t handed = 0;
  const auto hand = [&](std::uint32_t first, std::uint32_t count) {
    live.written(first, count);
    GroupStamp stamp;
    stamp.group_index = handed;
    stages.on_bscans(live, first, count, stamp);
    ++handed;
  };
#if IOCT_GPU_WITH_CUDA
  const cuda::BusTraffic before = cuda::bus_traffic();
#endif
  constexpr std::uint32_t kGroup = 4;
  live.volume = layered_volume(32, 96, 256, 11);
  for (std::uint32_t first = 0; first < 12; first += kGroup) {
    hand(first, kGroup);
    gate.wait_for_groups(handed);
  }
  // Folded: the pass of B-scans 12-15 is held while 16-27 are handed over in three groups.
  gate.close();
  hand(12, kGroup);
  gate.wait_for_groups(handed);  // its pass is done and held
  for (std::uint32_t first = 16; first < 28; first += kGroup) hand(first, kGroup);
  gate.open();
  gate.wait_for_groups(handed);
  hand(28, kGroup);
  gate.wait_for_groups(handed);
  // A second lap overwrites the first half, as the next volume does.
  const Volume second = layered_volume(32, 96, 256, 12);
  std::copy_n(second.pixels().data(), 16 * second.bscan_pixels(), live.volume.pixels().data());
  hand(0, 16);
  gate.wait_for_groups(handed);
  // A new geometry: the stages start over on it.
  live.volume = layered_volume(24, 80, 200, 13);
  for (std::uint32_t first = 0; first < 24; first += kGroup) {
    hand(first, kGroup);
    gate.wait_for_groups(handed);
  }

  StagesRun run;
#if IOCT_GPU_WITH_CUDA
  run.traffic = traffic_since(before);
  const cuda::BusTraffic before_switches = cuda::bus_traffic();
#endif
  run.passes = gate.passes();
  run.folded_passes = gate.folded_passes();
  for (const std::string& name : switches) {
    const std::uint64_t generation = stages.set_params({{"mode", name}});
    ViewSnapshot shot = stages.snapshot(std::chrono::seconds(30));
    EXPECT_GE(shot.generation, generation) << name;
    EXPECT_EQ(shot.params.at("mode"), name);
    run.switched.push_back(std::move(shot.image));
  }
  EXPECT_EQ(gate.passes(), run.passes) << "the changes of mode needed no pass";
#if IOCT_GPU_WITH_CUDA
  run.switch_traffic = traffic_since(before_switches);
#endif
  run.summary = stages.finish(dir);  // writes the frame still waiting
  if (frames) {
    shm::Frame frame;
    while (frames->read_next(frame)) {
      if (frame.meta.bscan_bytes == 0) continue;
      const std::span<const std::byte> bscan = frame.bscan();
      run.last_bscan_jpeg.assign(bscan.begin(), bscan.end());
      run.last_bscan_index = frame.meta.bscan_index;
    }
  }
  run.filtered = stages.filtered();
  run.surfaces = stages.surfaces();
  run.surfaces_after_last_pass = std::move(after_last_pass);
  run.frame = stages.frame();
  return run;
}

bool same_floats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](float x, float y) {
           return x == y || (std::isnan(x) && std::isnan(y));
         });
}

class DeviceChainTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const auto why = cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA: " << *why;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir(const std::string& name) const {
    const std::filesystem::path d = dir_ / name;
    std::filesystem::create_directories(d);
    return d;
  }
  const std::filesystem::path dir_ =
      std::filesystem::temp_directory_path() /
      ("ioct-device-chain-" +
       std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "-" +
       std::to_string(::getpid()));
};

// Within the renderers' tolerance (tests/render/cuda_vs_cpu_test.cpp).
void expect_close_frames(const render::RgbaImage& cpu, const render::RgbaImage& cuda,
                         const std::string& what) {
  ASSERT_EQ(cpu.width, cuda.width) << what;
  ASSERT_EQ(cpu.height, cuda.height) << what;
  ASSERT_GT(cpu.rgba.size(), 0u) << what;
  std::vector<int> d(cpu.rgba.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    d[i] = std::abs(int{cpu.rgba[i]} - int{cuda.rgba[i]});
    sum += d[i];
  }
  std::ranges::sort(d);
  const double mean = sum / static_cast<double>(d.size());
  const int p99 = d[static_cast<std::size_t>(0.99 * static_cast<double>(d.size() - 1))];
  EXPECT_LT(mean, 1.0) << what;
  EXPECT_LE(p99, 8) << what;
  std::printf("%s: mean %.3f p99 %d max %d\n", what.c_str(), mean, p99, d.back());
}

void expect_same_results(const StagesRun& cpu, const StagesRun& cuda, const std::string& what) {
  ASSERT_EQ(cpu.summary.at("problem"), "") << cpu.summary.dump(2);
  ASSERT_EQ(cuda.summary.at("problem"), "") << cuda.summary.dump(2);
  EXPECT_EQ(cuda.passes, cpu.passes) << what;
  EXPECT_EQ(cuda.folded_passes, 1u) << what << ": the held pass folds three groups";
  ASSERT_TRUE(cpu.filtered.same_shape(cuda.filtered)) << what;
  EXPECT_EQ(cuda.filtered.bscans(), 24u) << what << ": the new geometry";
  EXPECT_TRUE(std::ranges::equal(cpu.filtered.pixels(), cuda.filtered.pixels()))
      << what << ": filtered volume";
  EXPECT_TRUE(same_floats(cpu.surfaces.ilm, cuda.surfaces.ilm)) << what << ": ILM";
  EXPECT_TRUE(same_floats(cpu.surfaces.rpe, cuda.surfaces.rpe)) << what << ": RPE";
  EXPECT_TRUE(same_floats(cpu.surfaces.bm, cuda.surfaces.bm)) << what << ": BM";
  EXPECT_EQ(cpu.surfaces.state, cuda.surfaces.state) << what << ": states";
  EXPECT_EQ(cpu.surfaces.verdict, cuda.surfaces.verdict) << what << ": verdicts";

  expect_close_frames(cpu.frame, cuda.frame, what + ": frame");
  ASSERT_EQ(cpu.switched.size(), cuda.switched.size()) << what;
  for (std::size_t i = 0; i < cpu.switched.size(); ++i) {
    expect_close_frames(cpu.switched[i], cuda.switched[i],
                        what + ": frame after change of mode " + std::to_string(i + 1));
  }
  std::printf("%s: %llu passes\n", what.c_str(), static_cast<unsigned long long>(cuda.passes));
}

// The plan of hand-overs itself, on the CPU reference: the held pass folds three groups and every
// other hand-over gets a pass of its own (3 + 1 + 1 + 1 lap + 1 second lap + 6 new geometry).
TEST(DeviceChainPlan, HeldPassFoldsThreeGroupsOnTheCpuReference) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ioct-device-chain-plan-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const StagesRun cpu = run_stages(Backend::cpu, false, dir);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(cpu.summary.at("problem"), "") << cpu.summary.dump(2);
  EXPECT_EQ(cpu.passes, 13u);
  EXPECT_EQ(cpu.folded_passes, 1u);
  EXPECT_EQ(cpu.summary.at("groups").get<std::uint64_t>(), 15u);
  EXPECT_EQ(cpu.filtered.bscans(), 24u);
  EXPECT_EQ(cpu.surfaces.bscans, 24u);
}

TEST_F(DeviceChainTest, DeviceVolumeGivesTheCpuReferenceResultsWithoutCopyingTheVolume) {
  const StagesRun cpu = run_stages(Backend::cpu, false, dir("cpu"));
  const StagesRun cuda = run_stages(Backend::cuda, true, dir("cuda"));
  EXPECT_NE(cuda.summary.at("backends").get<std::string>().find("filter median-gauss cuda"),
            std::string::npos);
  expect_same_results(cpu, cuda, "device live volume");
#if IOCT_GPU_WITH_CUDA
  // Nothing of the volume crossed; what did (sums, ILM and RPE, the layer reference) is smaller
  // per pass than the smallest group handed over (4 B-scans of the second geometry).
  EXPECT_EQ(cuda.traffic.volume_to_host, 0u);
  EXPECT_EQ(cuda.traffic.volume_to_device, 0u);
  const std::uint64_t smallest_group = 4ull * 80 * 200;
  EXPECT_LT((cuda.traffic.other_to_host + cuda.traffic.other_to_device) / cuda.passes,
            smallest_group)
      << "to host " << cuda.traffic.other_to_host << " B, to device "
      << cuda.traffic.other_to_device << " B in " << cuda.passes << " passes";
  std::printf(
      "bus per pass: %.1f kB to host, %.1f kB to device (no volume bytes)\n",
      static_cast<double>(cuda.traffic.other_to_host) / 1e3 / static_cast<double>(cuda.passes),
      static_cast<double>(cuda.traffic.other_to_device) / 1e3 / static_cast<double>(cuda.passes));
#endif
}

// The B-scan beside the live frame, drawn on the device from the chain's filtered volume and
// surfaces (DeviceStageChain::bscan_overlay), is the CPU reference's picture: the same JPEG bytes
// in the last frame of the same passes (the encoder is deterministic, the surfaces identical).
TEST_F(DeviceChainTest, TheFramesBscanDrawnOnTheDeviceIsTheCpuReferences) {
  const std::string ring = "ioct-test-chain-bscan-" + std::to_string(::getpid());
  const StagesRun cpu =
      run_stages(Backend::cpu, false, dir("cpu"), render::RenderMode::enhanced, {}, ring + "-cpu");
  const StagesRun cuda = run_stages(Backend::cuda, true, dir("cuda"), render::RenderMode::enhanced,
                                    {}, ring + "-cuda");
  expect_same_results(cpu, cuda, "with frames published");
  ASSERT_FALSE(cpu.last_bscan_jpeg.empty()) << "no frame with a B-scan from the CPU stages";
  ASSERT_FALSE(cuda.last_bscan_jpeg.empty()) << "no frame with a B-scan from the CUDA stages";
  EXPECT_EQ(cuda.last_bscan_index, cpu.last_bscan_index);
  EXPECT_TRUE(cuda.last_bscan_jpeg == cpu.last_bscan_jpeg)
      << "B-scan " << cuda.last_bscan_index << ": " << cuda.last_bscan_jpeg.size() << " against "
      << cpu.last_bscan_jpeg.size() << " JPEG bytes";
}

// Weiss's modes: the renderer's per-B-scan median on the render stream, through the same passes
// (folded, second lap, new geometry), then changes of mode between Viehland's and Weiss's modes
// with no new group: every frame as the CPU reference's, and no volume byte crossing.
TEST_F(DeviceChainTest, LayerAwareModesRenderTheirOwnMedianAndSwitchLive) {
  const std::vector<std::string> switches = {"enhanced", "la-mip", "axial-colorization", "basic",
                                             "layer-aware"};
  const StagesRun cpu =
      run_stages(Backend::cpu, false, dir("cpu"), render::RenderMode::layer_aware, switches);
  const StagesRun cuda =
      run_stages(Backend::cuda, true, dir("cuda"), render::RenderMode::layer_aware, switches);
  EXPECT_NE(cuda.summary.at("backends").get<std::string>().find("render median-bscan"),
            std::string::npos)
      << cuda.summary.at("backends");
  expect_same_results(cpu, cuda, "layer-aware, device live volume");
#if IOCT_GPU_WITH_CUDA
  EXPECT_EQ(cuda.traffic.volume_to_host, 0u);
  EXPECT_EQ(cuda.traffic.volume_to_device, 0u);
  EXPECT_EQ(cuda.switch_traffic.volume_to_host, 0u) << "a change of mode re-filters on the device";
  EXPECT_EQ(cuda.switch_traffic.volume_to_device, 0u);
#endif
}

// With instrument detection the stages keep a host copy of the surfaces for the tips' distances,
// brought up to date after every pass with only the B-scans the passes changed since the last:
// after the last pass it is the CPU reference's and the whole device copy's, through the folded
// groups, the second lap and the new geometry.
TEST_F(DeviceChainTest, WithInstrumentsTheHostsSurfacesFollowEveryPass) {
  const StagesRun cpu =
      run_stages(Backend::cpu, false, dir("cpu"), render::RenderMode::enhanced, {}, {}, true);
  const StagesRun cuda =
      run_stages(Backend::cuda, true, dir("cuda"), render::RenderMode::enhanced, {}, {}, true);
  ASSERT_EQ(cuda.summary.at("problem"), "") << cuda.summary.dump(2);
  const segmentation::Surfaces& kept = cuda.surfaces_after_last_pass;
  ASSERT_EQ(kept.bscans, 24u) << "the new geometry's";
  ASSERT_EQ(kept.ascans, 80u);
  const segmentation::Surfaces& reference = cpu.surfaces_after_last_pass;
  ASSERT_EQ(reference.bscans, 24u);
  EXPECT_TRUE(same_floats(reference.ilm, kept.ilm)) << "ILM";
  EXPECT_TRUE(same_floats(reference.rpe, kept.rpe)) << "RPE";
  EXPECT_TRUE(same_floats(reference.bm, kept.bm)) << "BM";
  EXPECT_EQ(reference.state, kept.state) << "states";
  EXPECT_EQ(reference.verdict, kept.verdict) << "verdicts";
  // And every value as the whole device copy read back at the end.
  EXPECT_TRUE(same_floats(cuda.surfaces.ilm, kept.ilm)) << "ILM";
  EXPECT_TRUE(same_floats(cuda.surfaces.confidence, kept.confidence)) << "confidence";
  EXPECT_EQ(cuda.surfaces.state, kept.state) << "states";
  EXPECT_EQ(cuda.surfaces.verdict, kept.verdict) << "verdicts";
}

TEST_F(DeviceChainTest, HostVolumeIsUploadedAndGivesTheSameResults) {
  const StagesRun cpu = run_stages(Backend::cpu, false, dir("cpu"));
  const StagesRun cuda = run_stages(Backend::cuda, false, dir("cuda"));
  expect_same_results(cpu, cuda, "host live volume");
#if IOCT_GPU_WITH_CUDA
  // The counter sees an upload: the test above would notice volume bytes crossing.
  EXPECT_GT(cuda.traffic.volume_to_device, 0u);
  EXPECT_EQ(cuda.traffic.volume_to_host, 0u);
#endif
}

}  // namespace
}  // namespace ioct::gpu::live
