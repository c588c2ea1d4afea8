// The CUDA instrument detection against the CPU reference on the instrument scenes: the same
// floors, the same classification of every A-scan and bit-identical reflexes (the column code is
// the same integer arithmetic on both, the parabola the same float expression without fused
// multiply-add), hence the same tips; from a host volume (uploaded per group) and from a device
// volume read in place, as the live stages' device chain hands it. The tip's B-scan pair cut on
// the device is the host's, px for px. Skipped, saying why, where the CUDA detection cannot run.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/instruments/tip_bscans.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "same_tips.hpp"

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
  for (std::size_t i = 0; i < a.tips.size(); ++i) expect_same_tip(a.tips[i], b.tips[i], what);
  EXPECT_EQ(a.nearest, b.nearest) << what;
  EXPECT_EQ(a.warning, b.warning) << what;
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

// A scene's volume with its CPU segmentation, both detections and the volume's device copy.
struct SceneOnBoth {
  explicit SceneOnBoth(const InstrumentScene& scene)
      : s(make_scene_volume(scene)),
        cpu(gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, s.sampling, 2)),
        cuda(gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, s.sampling, 1)),
        device(s.volume.volume) {
    gpu::segmentation::make_segmenter(gpu::Backend::cpu, {}, s.sampling, 2)
        ->segment_volume(s.filtered, surfaces);
  }
  SceneVolume s;
  gpu::segmentation::Surfaces surfaces;
  std::unique_ptr<gpu::instruments::InstrumentDetector> cpu, cuda;
  DeviceCopy device;
};
#endif

TEST(InstrumentsCudaVsCpu, ADeviceVolumeReadInPlaceGivesTheCpusFindings) {
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (const auto why = cuda_detection_unavailable()) {
    GTEST_SKIP() << "CUDA instrument detection not tested: " << *why;
  }
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneOnBoth both(scene);
    const SceneVolume& s = both.s;
    const gpu::segmentation::Surfaces& surfaces = both.surfaces;
    const auto& cpu = both.cpu;
    const auto& cuda = both.cuda;
    const DeviceCopy& device = both.device;
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

// As the live stages run it: each group's classification begun on the device volume, the host
// busy meanwhile (here the CPU's detection of the same group), then ended; and the groups of a
// volume begun one after another with only the last ended (each begin ends the pending one);
// and a volume's tips located before its distances. The same findings as the CPU's, to the bit.
TEST(InstrumentsCudaVsCpu, AGroupBegunOnTheDeviceAndEndedLaterGivesTheCpusFindings) {
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (const auto why = cuda_detection_unavailable()) GTEST_SKIP() << *why;
  for (const InstrumentScene& scene : instrument_scenes()) {
    const SceneOnBoth both(scene);
    const gpu::Volume& volume = both.s.volume.volume;
    InstrumentFindings cpu, begun, all_begun;
    for (std::uint32_t first = 0; first < volume.bscans(); first += 16) {
      both.cuda->begin_group(both.device.ref(), {first, 16}, begun);
      both.cpu->detect_group(volume, {first, 16}, both.surfaces, cpu);
      both.cuda->end_group(both.surfaces, begun);
      expect_same_findings(cpu, begun, scene.name + " (begun, ended after the CPU's)");
    }
    for (std::uint32_t first = 0; first < volume.bscans(); first += 16) {
      both.cuda->begin_group(both.device.ref(), {first, 16}, all_begun);
    }
    both.cuda->end_group(both.surfaces, all_begun);
    expect_same_findings(cpu, all_begun, scene.name + " (every group begun, the last ended)");
    // The tips located before the surfaces are at hand, as the device chain does.
    InstrumentFindings located;
    both.cuda->begin_group(both.device.ref(), {0, volume.bscans()}, located);
    both.cuda->locate_tips(located);
    both.cuda->end_group(both.surfaces, located);
    expect_same_findings(cpu, located, scene.name + " (located, then ended)");
  }
#else
  GTEST_SKIP() << "this build has no CUDA instrument detection";
#endif
}

#if IOCT_INSTRUMENTS_HAVE_CUDA
void CUDART_CB hold_the_stream(void* milliseconds) {
  std::this_thread::sleep_for(std::chrono::milliseconds(*static_cast<int*>(milliseconds)));
}
#endif

// begin_group returns without waiting for the volume's stream, and its classification still
// comes after what that stream had queued: here the stream is held on the host for 200 ms, then
// fills the device volume (zeros before). While held, begin_group has returned; the findings
// ended after it are those of the filled volume. A group of no B-scans begun and ended changes
// nothing but the tips' search; a detect_volume while a group is pending settles that group first.
TEST(InstrumentsCudaVsCpu, BeginGroupReturnsAtOnceAndClassifiesAfterTheVolumesStream) {
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (const auto why = cuda_detection_unavailable()) GTEST_SKIP() << *why;
  const InstrumentScene scene = instrument_scenes().front();  // a copy: the list is a temporary
  const SceneOnBoth both(scene);
  const gpu::Volume& volume = both.s.volume.volume;
  InstrumentFindings cpu;
  both.cpu->detect_volume(volume, both.surfaces, cpu);
  ASSERT_FALSE(cpu.tips.empty()) << scene.name;

  gpu::cuda::PinnedArray<std::uint8_t> pinned(volume.pixels().size());
  std::memcpy(pinned.data(), volume.pixels().data(), volume.pixels().size());
  gpu::cuda::DeviceArray<std::uint8_t> pixels(volume.pixels().size());
  gpu::cuda::Stream writer;
  ASSERT_EQ(cudaMemsetAsync(pixels.data(), 0, pixels.bytes(), writer.get()), cudaSuccess);
  int hold_ms = 200;
  ASSERT_EQ(cudaLaunchHostFunc(writer.get(), hold_the_stream, &hold_ms), cudaSuccess);
  ASSERT_EQ(cudaMemcpyAsync(pixels.data(), pinned.data(), pixels.bytes(), cudaMemcpyHostToDevice,
                            writer.get()),
            cudaSuccess);
  const gpu::VolumeRef ref =
      gpu::VolumeRef::on_device(pixels.data(), gpu::VolumeDims::of(volume), writer.get());
  InstrumentFindings begun;
  both.cuda->begin_group(ref, {0, volume.bscans()}, begun);
  EXPECT_EQ(cudaStreamQuery(writer.get()), cudaErrorNotReady)
      << "begin_group waited for the volume's stream";
  both.cuda->end_group(both.surfaces, begun);
  expect_same_findings(cpu, begun, scene.name + " (the volume filled after begin_group)");

  both.cuda->begin_group(ref, {8, 0}, begun);
  both.cuda->end_group(both.surfaces, begun);
  expect_same_findings(cpu, begun, scene.name + " (a group of no B-scans)");

  InstrumentFindings pending, whole;
  both.cuda->begin_group(ref, {0, 16}, pending);
  both.cuda->detect_volume(volume, both.surfaces, whole);
  expect_same_findings(cpu, whole, scene.name + " (detect_volume with a group pending)");
  EXPECT_THROW(both.cuda->end_group(both.surfaces, pending), std::logic_error) << "settled";
#else
  GTEST_SKIP() << "this build has no CUDA instrument detection";
#endif
}

// Fresh random columns of every kind the classification tells apart, and of none: a metal
// reflex over its shadow (under tissue or not, with plateaus and rising px above its last peak),
// a translucent object over a dark gap over tissue, gaps a px too short, tissue from the top,
// objects at the top and the bottom, plain speckle and plain noise, at depths that are and are
// not multiples of 4, in B-scans of A-scans that do not fill the kernel's blocks. The CUDA
// detection (a warp per A-scan) must give the CPU's kind, reflex and front for each, bit for bit.
TEST(InstrumentsCudaVsCpu, RandomColumnsGiveTheCpusClassesAndReflexes) {
  if (const auto why = cuda_detection_unavailable()) {
    GTEST_SKIP() << "CUDA instrument detection not tested: " << *why;
  }
  const unsigned seed = std::random_device{}();
  std::printf("[ seed     ] %u\n", seed);
  std::mt19937 random(seed);
  const auto uniform = [&](int lo, int hi) {
    return std::uniform_int_distribution<int>(lo, hi)(random);
  };
  struct Case {
    std::uint32_t depth;
    double axial_um;  // 5.6 um px: gap 5, reflex 39, shadow 27 px
    bool every_class;
  };
  // Then the edges: A-scans shorter than a warp, a gap and a shadow longer than the A-scan
  // (1 um px: gap 30 px), and A-scans that end above skip_top (8 px).
  for (const Case& k : {Case{688, 5.605, true}, Case{97, 5.605, true}, Case{333, 5.605, true},
                        Case{1026, 5.605, true}, Case{20, 1.0, false}, Case{6, 5.605, false}}) {
    const std::uint32_t depth = k.depth;
    gpu::segmentation::VolumeSampling sampling;
    sampling.axial_um_per_px = k.axial_um;
    gpu::Volume v(16, 70, depth);
    const int floor = uniform(5, 40);
    const auto noise = [&] { return static_cast<std::uint8_t>(floor + uniform(-4, 4)); };
    for (std::uint32_t b = 0; b < v.bscans(); ++b) {
      for (std::uint32_t a = 0; a < v.ascans(); ++a) {
        std::uint8_t* c = v.bscan(b).data() + std::size_t{a} * depth;
        const int d = static_cast<int>(depth);
        for (int z = 0; z < d; ++z) c[z] = noise();
        const auto fill = [&](int from, int to, int lo, int hi) {
          for (int z = std::max(from, 0); z < std::min(to, d); ++z)
            c[z] = static_cast<std::uint8_t>(std::clamp(uniform(lo, hi), 0, 255));
        };
        const int kind = uniform(0, 7);
        const int at = uniform(0, d - 1);
        switch (kind) {
          case 0:  // noise only
            break;
          case 1:  // a metal reflex, its shadow to the bottom; sometimes a plateau at its peak
            fill(at, at + uniform(1, 45), floor + 30, 255);
            if (uniform(0, 1)) fill(at, at + 3, 200, 200);
            break;
          case 2:  // tissue above a metal reflex inside it
            fill(at, at + uniform(5, 30), floor + 10, floor + 120);
            fill(at + 30, at + 34, floor + 100, 255);
            break;
          case 3: {  // a translucent object, a dark gap (sometimes a px short), tissue
            const int object = uniform(1, 45), gap = uniform(3, 14);
            fill(at, at + object, floor + 41, 255);
            fill(at + object + gap, d, floor - 10, floor + 150);
            break;
          }
          case 4:  // tissue (speckle) from somewhere to the bottom
            fill(at, d, floor - 20, floor + 160);
            break;
          case 5:  // every px random
            fill(0, d, 0, 255);
            break;
          case 6:  // bright at the top rows and the last rows
            fill(0, uniform(1, 12), floor + 40, 255);
            fill(d - uniform(1, 4), d, floor + 40, 255);
            break;
          default:  // a short bright run with px that rise and fall above it, then dark
            for (int z = at; z < std::min(at + 40, d); ++z)
              c[z] = static_cast<std::uint8_t>(std::clamp(floor + 45 + 4 * ((z - at) % 9), 0, 255));
            break;
        }
      }
    }
    gpu::segmentation::Surfaces surfaces;  // none: the classification does not read them
    const auto cpu = gpu::instruments::make_instrument_detector(gpu::Backend::cpu, {}, sampling, 2);
    const auto cuda =
        gpu::instruments::make_instrument_detector(gpu::Backend::cuda, {}, sampling, 1);
    InstrumentFindings a, b;
    cpu->detect_group(v, {0, 16}, surfaces, a);
    cuda->detect_group(v, {0, 16}, surfaces, b);
    std::size_t shadow = 0, partial = 0;
    for (const auto kind : a.columns) {
      shadow += kind == gpu::instruments::ColumnKind::shadow;
      partial += kind == gpu::instruments::ColumnKind::partial;
    }
    std::printf("[ columns  ] depth %u: %zu shadow, %zu partial of %zu\n", depth, shadow, partial,
                a.columns.size());
    if (k.every_class) {
      EXPECT_GT(shadow, 0u) << "depth " << depth << ": the random columns reach every class";
      EXPECT_GT(partial, 0u) << "depth " << depth;
    }
    expect_same_findings(a, b, "random columns of depth " + std::to_string(depth));
  }
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
