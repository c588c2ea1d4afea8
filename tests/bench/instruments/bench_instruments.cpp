// Benchmark (not a test): the instrument detection of one group of 16 B-scans beside the
// segmentation of the same group (the anchor: the stage before it, whose budget the issue names),
// on the CPU and, in CUDA builds with a GPU, on the GPU. Host volumes on both (the CUDA stages
// upload the group), and on the GPU also the volume in device memory read in place, as the live
// stages' device chain hands it. Also the host's share: the tips from the mask alone (a group of
// 0 B-scans).
//
//   ioct-bench-instruments [--ascans 512] [--bscans 128] [--reps 30] [--backend both|cpu|cuda]
//                          [--sim-instrument SPEC]
//
// The scene: the forceps approaching at the centre of the field, or with --sim-instrument the tool
// of ioct-rt's option of that name over the whole field (e.g. the appliance's forceps scene).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "instrument_scenes.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"
#include "ioct/sim/instrument_spec.hpp"

#if IOCT_INSTRUMENTS_HAVE_CUDA
#include <cuda_runtime.h>

#include "ioct/gpu/cuda/cuda_support.hpp"
#endif

namespace {

using namespace ioct;
using Clock = std::chrono::steady_clock;

double median_ms(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <class F>
double time_ms(int reps, F&& f) {
  std::vector<double> samples;
  f();  // warm-up (allocations, first launch)
  for (int i = 0; i < reps; ++i) {
    const auto t0 = Clock::now();
    f();
    samples.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  return median_ms(samples);
}

void bench(gpu::Backend backend, const instruments_test::SceneVolume& s, int reps) {
  const char* name = backend == gpu::Backend::cpu ? "cpu" : "cuda";
  std::unique_ptr<gpu::instruments::InstrumentDetector> detector;
  std::unique_ptr<gpu::segmentation::Segmenter> segmenter;
  try {
    detector = gpu::instruments::make_instrument_detector(backend, {}, s.sampling, 2);
    segmenter = gpu::segmentation::make_segmenter(backend, {}, s.sampling, 2);
  } catch (const gpu::BackendUnavailable& e) {
    std::printf("%s: not measured: %s\n", name, e.what());
    return;
  }
  gpu::segmentation::Surfaces surfaces;
  segmenter->segment_volume(s.filtered, surfaces);
  gpu::instruments::InstrumentFindings findings;
  detector->detect_volume(s.volume.volume, surfaces, findings);
  const std::uint32_t first = s.volume.volume.bscans() / 2 - 8;
  const double segment = time_ms(reps, [&] {
    segmenter->segment_group(s.filtered, {first, 16}, surfaces);
  });
  const double detect = time_ms(reps, [&] {
    detector->detect_group(s.volume.volume, {first, 16}, surfaces, findings);
  });
  const double tips = time_ms(reps, [&] {
    detector->detect_group(s.volume.volume, {first, 0}, surfaces, findings);
  });
  std::printf(
      "%s: per group of 16 B-scans (%u A-scans x %u px): instruments %.3f ms (of which tips on "
      "the host %.3f ms) beside segmentation %.3f ms (anchor): %.2fx; %zu tip(s): %s\n",
      name, s.volume.volume.ascans(), s.volume.volume.depth(), detect, tips, segment,
      detect / segment, findings.tips.size(), gpu::instruments::describe(findings).c_str());
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (backend == gpu::Backend::cuda) {
    const gpu::Volume& v = s.volume.volume;
    gpu::cuda::DeviceArray<std::uint8_t> pixels(v.pixels().size());
    gpu::cuda::Stream stream;
    if (cudaMemcpy(pixels.data(), v.pixels().data(), v.pixels().size(), cudaMemcpyHostToDevice) !=
        cudaSuccess) {
      std::printf("cuda, device volume: not measured: the copy to the device failed\n");
      return;
    }
    const gpu::VolumeRef ref =
        gpu::VolumeRef::on_device(pixels.data(), gpu::VolumeDims::of(v), stream.get());
    const double in_place = time_ms(reps, [&] {
      detector->detect_group(ref, {first, 16}, surfaces, findings);
    });
    std::printf(
        "cuda, device volume read in place: instruments %.3f ms beside segmentation %.3f ms "
        "(anchor): %.2fx; the host volume's upload saved %.3f ms\n",
        in_place, segment, in_place / segment, detect - in_place);
  }
#endif
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"instrument detection per group beside the segmentation of the same group"};
  std::uint32_t ascans = 512, bscans = 128;
  int reps = 30;
  std::string backend = "both";
  std::string tool_spec;
  app.add_option("--ascans", ascans, "A-scans per B-scan")->check(CLI::Range(16u, 4096u));
  app.add_option("--bscans", bscans, "B-scans (a multiple of 16)")->check(CLI::Range(16u, 1024u));
  app.add_option("--reps", reps, "timed repetitions (median)")->check(CLI::Range(1, 10000));
  app.add_option("--backend", backend, "both, cpu or cuda")
      ->check(CLI::IsMember({"both", "cpu", "cuda"}));
  app.add_option("--sim-instrument", tool_spec,
                 "the tool over the whole field instead, as ioct-rt's --sim-instrument");
  CLI11_PARSE(app, argc, argv);
  if (bscans % 16 != 0) {
    std::fprintf(stderr, "--bscans %u: must be a multiple of 16\n", bscans);
    return 2;
  }
  instruments_test::SceneVolume s;
  if (!tool_spec.empty()) {
    std::printf("simulating %s over the field at %u x %u A-scans...\n", tool_spec.c_str(), ascans,
                bscans);
    try {
      s = instruments_test::make_field_volume(
          {sim::parse_instrument_spec(tool_spec, "--sim-instrument")}, ascans, bscans);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "ioct-bench-instruments: %s\n", e.what());
      return 2;
    }
  } else {
    std::printf("simulating the forceps scene at %u x %u A-scans...\n", ascans, bscans);
    // The forceps approaching, at the centre of the field (the raster spans all of it).
    instruments_test::InstrumentScene scene = instruments_test::instrument_scenes()[0];
    scene.tip_x = 0.0f;
    scene.tip_y = 0.0f;
    s = instruments_test::make_scene_volume(scene, ascans, bscans);
  }
  if (backend != "cuda") bench(gpu::Backend::cpu, s, reps);
  if (backend != "cpu") bench(gpu::Backend::cuda, s, reps);
  return 0;
}
