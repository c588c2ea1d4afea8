// ioct-bench-segmentation: the CUDA segmentation of one group (16 B-scans of 512 A-scans x 688 px
// by default) of a simulated 128-B-scan volume that already lives on the GPU, beside two anchors
// measured in the same run on the same device: a device-to-device copy of the group, and the
// volume filters (median 3x3x3 + Gaussian 5x5) of the same group. Times are CUDA events around the
// enqueued work, per group, over every group of the volume in turn; the median and the 99th
// percentile are printed, with the time of each stage, and written as JSON with --json.
#include <cuda_runtime_api.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "device_timing.hpp"
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/filters/cuda_volume_filter.hpp"
#include "ioct/gpu/filters/gaussian_taps.hpp"
#include "ioct/gpu/segmentation/cpu_segmenter.hpp"
#include "ioct/gpu/segmentation/cuda_segmenter.hpp"
#include "simulated_volume.hpp"

namespace {

using namespace ioct;
using namespace ioct::gpu::segmentation;

struct Timing {
  double median_us = 0.0;
  double p99_us = 0.0;
  double min_us = 0.0;
};

Timing summarize(std::vector<double> us) {
  std::sort(us.begin(), us.end());
  Timing t;
  t.median_us = us[us.size() / 2];
  t.p99_us = us[std::min(us.size() - 1, us.size() * 99 / 100)];
  t.min_us = us.front();
  return t;
}

nlohmann::json to_json(const Timing& t) {
  return {{"median_us", t.median_us}, {"p99_us", t.p99_us}, {"min_us", t.min_us}};
}

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t ascans = 512;
  std::uint32_t bscans = 128;
  std::uint32_t group = 16;
  std::uint32_t samples = 1376;
  int rounds = 40;
  std::string json_path;
  CLI::App app{"ioct-bench-segmentation: CUDA segmentation of a group beside same-run anchors"};
  app.add_option("--ascans", ascans, "A-scans per B-scan");
  app.add_option("--bscans", bscans, "B-scans per volume");
  app.add_option("--group", group, "B-scans per group");
  app.add_option("--samples", samples, "samples per A-scan (depth = samples / 2)");
  app.add_option("--rounds", rounds, "times every group of the volume is segmented");
  app.add_option("--json", json_path, "write the figures as JSON here");
  CLI11_PARSE(app, argc, argv);

  try {
    if (const std::string problem = cuda_segmentation_problem(); !problem.empty()) {
      std::cerr << "ioct-bench-segmentation: " << problem << "\n";
      return 2;
    }
    cudaDeviceProp properties{};
    IOCT_CUDA_CHECK(cudaGetDeviceProperties(&properties, 0));

    // The simulated retina, processed and filtered on the CPU as the tests do.
    const auto t0 = std::chrono::steady_clock::now();
    seg_test::SimulatedVolumeSpec spec;
    spec.ascans = ascans;
    spec.bscans = bscans;
    spec.bscans_per_group = group;
    spec.samples_per_ascan = samples;
    const seg_test::SimulatedVolume simulated = seg_test::make_simulated_volume(spec);
    const gpu::Volume& volume = simulated.volume;
    VolumeSampling sampling;
    sampling.axial_um_per_px = simulated.axial_um_per_px;
    sampling.ascan_spacing_um = 6000.0 / (ascans - 1);
    sampling.bscan_spacing_um = 6000.0 / (bscans - 1);
    std::printf("volume %u x %u x %u simulated in %.1f s\n", volume.bscans(), volume.ascans(),
                volume.depth(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());

    CudaSegmenter segmenter({}, sampling);
    segmenter.set_use_graphs(false);
    cudaStream_t stream = segmenter.stream();
    const std::size_t bytes = volume.pixels().size();
    gpu::cuda::DeviceArray<std::uint8_t> device_volume(bytes);
    gpu::cuda::DeviceArray<std::uint8_t> scratch(bytes);
    gpu::cuda::DeviceArray<std::uint8_t> filtered(bytes);
    IOCT_CUDA_CHECK(
        cudaMemcpy(device_volume.data(), volume.pixels().data(), bytes, cudaMemcpyHostToDevice));
    segmenter.prepare(volume.bscans(), volume.ascans(), volume.depth());
    const std::uint32_t groups = volume.bscans() / group;
    for (std::uint32_t g = 0; g < groups; ++g) {  // warm-up: every B-scan segmented once
      segmenter.enqueue_group(device_volume.data(), {g * group, group}, stream);
    }
    IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));

    std::vector<cudaEvent_t> stage_events(CudaSegmenter::kStages);
    for (cudaEvent_t& e : stage_events) IOCT_CUDA_CHECK(cudaEventCreate(&e));
    gpu::cuda::TimingEvent segment_start, segment_stop;
    std::vector<double> segment_us, copy_us, filter_us;
    std::vector<std::vector<double>> stage_us(CudaSegmenter::kStages);
    const std::size_t group_bytes = static_cast<std::size_t>(group) * volume.bscan_pixels();
    const gpu::filters::GaussianTaps taps = gpu::filters::make_gaussian_taps(1.0);
    const gpu::VolumeDims dims{volume.bscans(), volume.ascans(), volume.depth()};
    for (int round = 0; round < rounds; ++round) {
      for (std::uint32_t g = 0; g < groups; ++g) {
        const std::uint32_t first = g * group;
        // Anchor 1: a device copy of the group.
        copy_us.push_back(
            1000.0 * bench::device_ms(stream, [&] {
              IOCT_CUDA_CHECK(cudaMemcpyAsync(scratch.data() + first * volume.bscan_pixels(),
                                              device_volume.data() + first * volume.bscan_pixels(),
                                              group_bytes, cudaMemcpyDeviceToDevice, stream));
            }));
        // Anchor 2: the volume filters of the group's outputs.
        const gpu::filters::BscanRange outputs =
            gpu::filters::outputs_affected_by({first, group}, volume.bscans());
        filter_us.push_back(1000.0 * bench::device_ms(stream, [&] {
                              gpu::filters::enqueue_volume_filter(
                                  device_volume.data(), scratch.data(), filtered.data(), dims,
                                  outputs, {}, taps, {}, stream);
                            }));
        // The segmentation of the group, with its stages.
        segmenter.set_stage_events(stage_events.data());
        segment_start.record(stream);
        segmenter.enqueue_group(device_volume.data(), {first, group}, stream);
        segment_stop.record(stream);
        segment_stop.synchronize();
        segment_us.push_back(1000.0 * segment_stop.ms_since(segment_start));
        segmenter.set_stage_events(nullptr);
        cudaEvent_t previous = segment_start.get();
        for (int s = 0; s < CudaSegmenter::kStages; ++s) {
          float ms = 0.0f;
          IOCT_CUDA_CHECK(cudaEventElapsedTime(&ms, previous, stage_events[s]));
          stage_us[s].push_back(1000.0 * ms);
          previous = stage_events[s];
        }
      }
    }

    // The same groups through the segmenter's CUDA graphs (captured on first use).
    segmenter.set_use_graphs(true);
    for (std::uint32_t g = 0; g < groups; ++g) {
      segmenter.enqueue_group(device_volume.data(), {g * group, group}, stream);
    }
    IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
    std::vector<double> graph_us;
    for (int round = 0; round < rounds; ++round) {
      for (std::uint32_t g = 0; g < groups; ++g) {
        graph_us.push_back(
            1000.0 * bench::device_ms(stream, [&] {
              segmenter.enqueue_group(device_volume.data(), {g * group, group}, stream);
            }));
      }
    }
    for (cudaEvent_t e : stage_events) cudaEventDestroy(e);

    // The CPU reference on the same volume, for scale.
    CpuSegmenter cpu({}, sampling, 2);
    Surfaces cpu_surfaces;
    cpu.segment_volume(volume, cpu_surfaces);
    std::vector<double> cpu_us;
    for (std::uint32_t g = 0; g < groups; ++g) {
      const auto start = std::chrono::steady_clock::now();
      cpu.segment_group(volume, {g * group, group}, cpu_surfaces);
      cpu_us.push_back(
          std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start)
              .count());
    }

    const Timing segment = summarize(segment_us);
    const Timing graph = summarize(graph_us);
    const Timing copy = summarize(copy_us);
    const Timing filter = summarize(filter_us);
    const Timing cpu_time = summarize(cpu_us);
    const double copy_gbps = static_cast<double>(group_bytes) / (copy.median_us * 1e3);
    static const char* const kStageNames[CudaSegmenter::kStages] = {
        "coarse_costs", "coarse_search", "ilm_costs", "ilm_search",
        "rpe_costs",    "rpe_search",    "fits",      "finishing"};
    std::printf("device: %s (%d SMs)\n", properties.name, properties.multiProcessorCount);
    std::printf("group: %u B-scans x %u A-scans x %u px (%.2f MB)\n", group, volume.ascans(),
                volume.depth(), static_cast<double>(group_bytes) / 1e6);
    std::printf("segmentation, stream launches: median %.1f us, p99 %.1f us, min %.1f us\n",
                segment.median_us, segment.p99_us, segment.min_us);
    std::printf("segmentation, CUDA graph:      median %.1f us, p99 %.1f us, min %.1f us\n",
                graph.median_us, graph.p99_us, graph.min_us);
    for (int s = 0; s < CudaSegmenter::kStages; ++s) {
      const Timing t = summarize(stage_us[s]);
      std::printf("  stage %-14s median %6.1f us\n", kStageNames[s], t.median_us);
    }
    std::printf(
        "anchor device copy of the group: median %.1f us (%.0f GB/s); segmentation = %.1f "
        "copies\n",
        copy.median_us, copy_gbps, segment.median_us / copy.median_us);
    std::printf(
        "anchor filters (median 3x3x3 + Gauss 5x5) of the group: median %.1f us; "
        "segmentation = %.2f x filters\n",
        filter.median_us, segment.median_us / filter.median_us);
    std::printf("CPU reference (2 threads): median %.1f ms per group\n", cpu_time.median_us / 1e3);
    if (!json_path.empty()) {
      nlohmann::json stages;
      for (int s = 0; s < CudaSegmenter::kStages; ++s) {
        stages[kStageNames[s]] = to_json(summarize(stage_us[s]));
      }
      const nlohmann::json out = {
          {"device", properties.name},
          {"group", {{"bscans", group}, {"ascans", volume.ascans()}, {"depth", volume.depth()}}},
          {"segmentation_stream", to_json(segment)},
          {"segmentation_graph", to_json(graph)},
          {"stages", stages},
          {"anchor_device_copy", to_json(copy)},
          {"anchor_device_copy_gbps", copy_gbps},
          {"anchor_filters", to_json(filter)},
          {"cpu_reference_2_threads", to_json(cpu_time)},
          {"rounds", rounds}};
      std::ofstream(json_path) << out.dump(2) << "\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "ioct-bench-segmentation: " << e.what() << "\n";
    return 1;
  }
}
