// The CUDA instrument detection against the CPU reference on the instrument scenes: the same
// floors, the same classification of every A-scan and bit-identical reflexes (the column code is
// the same integer arithmetic on both, the parabola the same float expression without fused
// multiply-add), hence the same tips; from a host volume (uploaded per group) and from a device
// volume read in place, as the live stages' device chain hands it. The tip's B-scan pair cut on
// the device is the host's, px for px. Skipped, saying why, where the CUDA detection cannot run.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <optional>
#include <random>
#include <string>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"

#if IOCT_INSTRUMENTS_HAVE_CUDA
#include "ioct/gpu/cuda/cuda_support.hpp"
#endif

namespace ioct::instruments_test {
namespace {

using gpu::instruments::InstrumentFindings;

// The CUDA detection can run here; otherwise why not.
std::optional<std::string> cuda_detection_unavailable() {
  try {
    gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, {}, 1);
  } catch (const gpu::BackendUnavailable& e) {
    return e.what();
  }
  return std::nullopt;
}

void expect_same_findings(const InstrumentFindings& a, const InstrumentFindings& b,
                          const std::string& what) {
  ASSERT_EQ(a.floor, b.floor) << what;
  ASSERT_EQ(a.columns, b.columns) << what;
  ASSERT_EQ(a.reflex_px.size(), b.reflex_px.size()) << what;
  ASSERT_EQ(0,
            std::memcmp(a.reflex_px.data(), b.reflex_px.data(), a.reflex_px.size() * sizeof(float)))
      << what;
  ASSERT_EQ(a.front_px.size(), b.front_px.size()) << what;
  ASSERT_EQ(0, std::memcmp(a.front_px.data(), b.front_px.data(), a.front_px.size() * sizeof(float)))
      << what;
  ASSERT_EQ(a.tips.size(), b.tips.size()) << what;
  for (std::size_t i = 0; i < a.tips.size(); ++i) {
    EXPECT_EQ(a.tips[i].ascan, b.tips[i].ascan) << what;
    EXPECT_EQ(a.tips[i].depth_px, b.tips[i].depth_px) << what;
    EXPECT_EQ(a.tips[i].to_rpe_um, b.tips[i].to_rpe_um) << what;
  }
}

TEST(InstrumentsCudaVsCpu, SameMaskReflexesAndTipsGroupByGroup) {
  if (const auto why = cuda_detection_unavailable()) {
    GTEST_SKIP() << "CUDA instrument detection not tested: " << *why;
  }
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneVolume s = make_scene_volume(scene);
    const auto cuda =
        gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, s.sampling, 1);
    gpu::segmentation::Surfaces surfaces;
    gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
        ->segment_volume(s.filtered, surfaces);
    const auto cpu =
        gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2);
    InstrumentFindings a, b;
    // Group by group, as live: 16 B-scans at a time.
    for (std::uint32_t first = 0; first < s.volume.volume.bscans(); first += 16) {
      cpu->detect_group(s.volume.volume, {first, 16}, surfaces, a);
      cuda->detect_group(s.volume.volume, {first, 16}, surfaces, b);
    }
    expect_same_findings(a, b, scene.name);
  }
}

#if IOCT_INSTRUMENTS_HAVE_CUDA
// A volume's copy in device memory, as the live stages' device chain holds its input.
class DeviceCopy {
 public:
  explicit DeviceCopy(const gpu::Volume& v) : pixels_(v.pixels().size()) {
    EXPECT_EQ(
        cudaMemcpy(pixels_.data(), v.pixels().data(), v.pixels().size(), cudaMemcpyHostToDevice),
        cudaSuccess);
    dims_ = gpu::VolumeDims::of(v);
  }
  gpu::VolumeRef ref() const {
    return gpu::VolumeRef::on_device(pixels_.data(), dims_, stream_.get());
  }

 private:
  gpu::cuda::DeviceArray<std::uint8_t> pixels_;
  gpu::cuda::Stream stream_;
  gpu::VolumeDims dims_;
};
#endif

TEST(InstrumentsCudaVsCpu, ADeviceVolumeReadInPlaceGivesTheCpusFindings) {
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (const auto why = cuda_detection_unavailable()) {
    GTEST_SKIP() << "CUDA instrument detection not tested: " << *why;
  }
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneVolume s = make_scene_volume(scene);
    gpu::segmentation::Surfaces surfaces;
    gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
        ->segment_volume(s.filtered, surfaces);
    const auto cpu =
        gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2);
    const auto cuda =
        gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, s.sampling, 1);
    const DeviceCopy device(s.volume.volume);
    const gpu::cuda::BusTraffic before = gpu::cuda::bus_traffic();
    InstrumentFindings a, b;
    for (std::uint32_t first = 0; first < s.volume.volume.bscans(); first += 16) {
      cpu->detect_group(s.volume.volume, {first, 16}, surfaces, a);
      cuda->detect_group(device.ref(), {first, 16}, surfaces, b);
    }
    EXPECT_EQ(gpu::cuda::bus_traffic().volume_to_device, before.volume_to_device)
        << scene.name << ": a B-scan was uploaded";
    expect_same_findings(a, b, scene.name + " (device volume)");
    // The CPU detection refuses a device volume, naming why.
    EXPECT_THROW(cpu->detect_group(device.ref(), {0, 16}, surfaces, a), std::invalid_argument);
  }
#else
  GTEST_SKIP() << "this build has no CUDA instrument detection";
#endif
}

TEST(InstrumentsCudaVsCpu, TheTipsBscanPairCutOnTheDeviceIsTheHostsPxForPx) {
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (const auto why = gpu::cuda_unavailable_reason()) GTEST_SKIP() << "no CUDA: " << *why;
  // Fresh random volumes and tips at fresh places, inside, on the edge and outside the field.
  std::mt19937 random(std::random_device{}());
  std::uniform_int_distribution<int> level(0, 255);
  std::uniform_real_distribution<double> unit(-0.2, 1.2), angle(0.0, 6.283185307179586);
  gpu::segmentation::VolumeSampling sampling;
  sampling.ascan_spacing_um = 11.7;
  sampling.bscan_spacing_um = 47.0;
  for (int trial = 0; trial < 6; ++trial) {
    gpu::Volume v(17 + trial, 93, 61 + 7 * trial);
    for (std::uint8_t& p : v.pixels()) p = static_cast<std::uint8_t>(level(random));
    gpu::instruments::InstrumentTip tip;
    tip.x_um = unit(random) * v.ascans() * sampling.ascan_spacing_um;
    tip.y_um = unit(random) * v.bscans() * sampling.bscan_spacing_um;
    const double a = angle(random);
    tip.axis_x = std::cos(a);
    tip.axis_y = std::sin(a);
    gpu::instruments::TipBscans host, device;
    gpu::instruments::cut_tip_bscans(v, tip, sampling, host, 400.0);
    const DeviceCopy copy(v);
    gpu::instruments::cut_tip_bscans(copy.ref(), tip, sampling, device, 400.0);
    ASSERT_EQ(host.width, device.width);
    ASSERT_EQ(host.height, device.height);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < host.pixels.size(); ++i)
      differ += host.pixels[i] != device.pixels[i];
    EXPECT_EQ(differ, 0u) << "trial " << trial << " of " << host.pixels.size() << " px";
  }
#else
  GTEST_SKIP() << "this build has no CUDA instrument detection";
#endif
}

}  // namespace
}  // namespace ioct::instruments_test
