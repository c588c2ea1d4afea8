// ioct-bench-filters: the CUDA volume filters on a device-resident volume (default 128 x 512 x
// 688 u8), every kernel variant timed with CUDA events beside a same-run anchor (a device-to-device
// copy of the volume), and the result checked bit for bit against the CPU filter.
// tests/bench/filters/bench_filters.py runs it and times cupyx on the same volume.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "ioct/gpu/filters/cpu_volume_filter.hpp"
#include "ioct/gpu/filters/cuda_volume_filter.hpp"

namespace {

using namespace ioct::gpu;
using namespace ioct::gpu::filters;

struct Timing {
  std::string name;
  double median_ms = 0, min_ms = 0, max_ms = 0;
};

// Times `launch` (enqueued on `stream`) `reps` times after `warmup` untimed runs; one pair of
// events per run.
Timing time_on_device(const std::string& name, cudaStream_t stream, int warmup, int reps,
                      const std::function<void()>& launch) {
  for (int i = 0; i < warmup; ++i) launch();
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
  std::vector<cudaEvent_t> events(2 * reps);
  for (cudaEvent_t& e : events) IOCT_CUDA_CHECK(cudaEventCreate(&e));
  for (int i = 0; i < reps; ++i) {
    IOCT_CUDA_CHECK(cudaEventRecord(events[2 * i], stream));
    launch();
    IOCT_CUDA_CHECK(cudaEventRecord(events[2 * i + 1], stream));
  }
  IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
  std::vector<double> ms(reps);
  for (int i = 0; i < reps; ++i) {
    float elapsed = 0;
    IOCT_CUDA_CHECK(cudaEventElapsedTime(&elapsed, events[2 * i], events[2 * i + 1]));
    ms[i] = elapsed;
  }
  for (cudaEvent_t e : events) cudaEventDestroy(e);
  std::sort(ms.begin(), ms.end());
  return {name, ms[ms.size() / 2], ms.front(), ms.back()};
}

std::vector<std::uint32_t> parse_dims(const std::string& text) {
  std::vector<std::uint32_t> dims;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    dims.push_back(static_cast<std::uint32_t>(
        std::stoul(text.substr(start, comma == std::string::npos ? comma : comma - start))));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (dims.size() != 3 || dims[0] == 0 || dims[1] == 0 || dims[2] == 0) {
    throw std::invalid_argument("--dims wants B,A,D (B-scans, A-scans, depth), all positive");
  }
  return dims;
}

void write_raw(const std::string& path, std::span<const std::uint8_t> bytes) {
  std::ofstream file(path, std::ios::binary);
  file.write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  if (!file) throw std::runtime_error("cannot write " + path);
}

std::string host_time() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S", std::gmtime(&now));
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  std::string dims_text = "128,512,688";
  std::string input, output_median, output_filtered, json_path;
  int reps = 50, warmup = 5, device = 0;
  double sigma = 1.0;
  bool cpu_check = true;
  CLI::App app{"ioct-bench-filters: CUDA median 3x3x3 + Gaussian 5x5 on a device-resident volume"};
  app.option_defaults()->always_capture_default();
  app.add_option("--dims", dims_text, "B-scans,A-scans,depth of the volume");
  app.add_option("--input", input, "raw u8 volume [bscan][ascan][depth]; default: random");
  app.add_option("--output-median", output_median, "write the median volume (raw u8)");
  app.add_option("--output-filtered", output_filtered, "write median + Gaussian (raw u8)");
  app.add_option("--json", json_path, "write every figure as JSON");
  app.add_option("--reps", reps, "timed runs per figure")->check(CLI::Range(1, 100000));
  app.add_option("--warmup", warmup, "untimed runs first")->check(CLI::Range(0, 1000));
  app.add_option("--sigma", sigma, "Gaussian sigma (px)");
  app.add_option("--device", device, "CUDA device");
  app.add_flag("!--no-cpu-check", cpu_check, "skip the bit-exact comparison with the CPU filter");
  CLI11_PARSE(app, argc, argv);

  try {
    const std::vector<std::uint32_t> d = parse_dims(dims_text);
    Volume volume(d[0], d[1], d[2]);
    const std::size_t bytes = volume.pixels().size();
    if (input.empty()) {
      std::mt19937 rng(1);
      for (std::uint32_t b = 0; b < d[0]; ++b) {
        for (std::uint8_t& p : volume.bscan(b)) p = static_cast<std::uint8_t>(rng() >> 24);
      }
    } else {
      std::ifstream file(input, std::ios::binary | std::ios::ate);
      if (!file || static_cast<std::size_t>(file.tellg()) != bytes) {
        throw std::runtime_error(input + ": missing or not " + std::to_string(bytes) + " bytes");
      }
      file.seekg(0);
      file.read(reinterpret_cast<char*>(volume.bscan(0).data()),
                static_cast<std::streamsize>(bytes));
    }

    IOCT_CUDA_CHECK(cudaSetDevice(device));
    cudaDeviceProp prop{};
    IOCT_CUDA_CHECK(cudaGetDeviceProperties(&prop, device));
    int driver = 0, runtime = 0;
    cudaDriverGetVersion(&driver);
    cudaRuntimeGetVersion(&runtime);
    std::cout << "ioct-bench-filters " << host_time() << " UTC\n"
              << "device " << device << ": " << prop.name << ", " << prop.multiProcessorCount
              << " SMs, compute " << prop.major << "." << prop.minor << ", driver " << driver
              << ", runtime " << runtime << "\n"
              << "volume " << d[0] << " x " << d[1] << " x " << d[2] << " u8 ("
              << (input.empty() ? "random" : input) << "), " << reps << " timed runs after "
              << warmup << " warm-up, median [min, max]\n\n";

    cudaStream_t stream;
    IOCT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking));
    cuda::DeviceArray<std::uint8_t> in(bytes), median(bytes), out(bytes), copy(bytes);
    IOCT_CUDA_CHECK(cudaMemcpy(in.data(), volume.pixels().data(), bytes, cudaMemcpyHostToDevice));
    const VolumeDims dims{d[0], d[1], d[2]};
    const BscanRange all{0, d[0]};
    VolumeFilterConfig config;
    config.gaussian_sigma = sigma;
    const GaussianTaps taps = make_gaussian_taps(sigma);

    std::vector<Timing> timings;
    const auto add = [&](const Timing& t) {
      timings.push_back(t);
      std::printf("  %-44s %9.4f ms  [%.4f, %.4f]\n", t.name.c_str(), t.median_ms, t.min_ms,
                  t.max_ms);
    };
    const Timing anchor =
        time_on_device("anchor: device copy of the volume", stream, warmup, reps, [&] {
          IOCT_CUDA_CHECK(
              cudaMemcpyAsync(copy.data(), in.data(), bytes, cudaMemcpyDeviceToDevice, stream));
        });
    add(anchor);

    // Every median variant; the fastest sorted-runs one serves the combined figures.
    struct Variant {
      CudaFilterTuning tuning;
      std::string name;
    };
    std::vector<Variant> variants;
    for (MedianKernel kernel : {MedianKernel::sorted_runs_u16x2, MedianKernel::sorted_runs_f16x2,
                                MedianKernel::sorted_runs_u8x4}) {
      for (std::uint32_t walk : {8u, 16u, 32u, 64u}) {
        variants.push_back(
            {{kernel, walk},
             "median " + std::string(to_string(kernel)) + ", walk " + std::to_string(walk)});
      }
    }
    variants.push_back({{MedianKernel::forgetful, 16}, "median forgetful (paper), walk 16"});
    std::vector<std::uint8_t> reference_median;
    std::vector<std::uint8_t> result(bytes);
    Timing best{};
    CudaFilterTuning best_tuning;
    bool variants_agree = true;
    for (const Variant& v : variants) {
      const Timing t = time_on_device(v.name, stream, warmup, reps, [&] {
        enqueue_median(in.data(), median.data(), dims, all, MedianWindow::volume_3x3x3, v.tuning,
                       stream);
      });
      add(t);
      IOCT_CUDA_CHECK(cudaMemcpy(result.data(), median.data(), bytes, cudaMemcpyDeviceToHost));
      if (reference_median.empty()) {
        reference_median = result;
      } else if (result != reference_median) {
        variants_agree = false;
        std::cout << "    ^ DIFFERS from the first variant's median\n";
      }
      if (v.tuning.median_kernel != MedianKernel::forgetful &&
          (best.name.empty() || t.median_ms < best.median_ms)) {
        best = t;
        best_tuning = v.tuning;
      }
    }
    Timing best_gaussian{};
    for (std::uint32_t walk : {16u, 32u, 64u}) {
      CudaFilterTuning tuning;
      tuning.ascans_per_gaussian_thread = walk;
      const Timing t = time_on_device(
          "Gaussian 5x5 per B-scan, walk " + std::to_string(walk), stream, warmup, reps,
          [&] { enqueue_gaussian(in.data(), out.data(), dims, all, taps, tuning, stream); });
      add(t);
      if (best_gaussian.name.empty() || t.median_ms < best_gaussian.median_ms) {
        best_gaussian = t;
        best_tuning.ascans_per_gaussian_thread = walk;
      }
    }
    const std::string best_median_name = std::string(to_string(best_tuning.median_kernel)) +
                                         ", walk " + std::to_string(best_tuning.bscans_per_thread);
    const std::string best_name = best_median_name + "; Gaussian walk " +
                                  std::to_string(best_tuning.ascans_per_gaussian_thread);
    const Timing combined =
        time_on_device("median + Gaussian (" + best_name + ")", stream, warmup, reps, [&] {
          enqueue_volume_filter(in.data(), median.data(), out.data(), dims, all, config, taps,
                                best_tuning, stream);
        });
    add(combined);
    const std::uint32_t group = std::min<std::uint32_t>(16, d[0]);
    const BscanRange changed{(d[0] - group) / 2, group};
    const BscanRange outputs = outputs_affected_by(changed, d[0]);
    const Timing incremental =
        time_on_device("one group of " + std::to_string(group) + " B-scans (" +
                           std::to_string(outputs.count) + " outputs)",
                       stream, warmup, reps, [&] {
                         enqueue_volume_filter(in.data(), median.data(), out.data(), dims, outputs,
                                               config, taps, best_tuning, stream);
                       });
    add(incremental);
    // Weiss et al. 2019: the 3x3 median per B-scan alone (their filter of the layer-aware DVR).
    add(time_on_device("median 3x3 per B-scan (Weiss), whole volume", stream, warmup, reps, [&] {
      enqueue_median(in.data(), out.data(), dims, all, MedianWindow::bscan_3x3, best_tuning,
                     stream);
    }));

    // The full filter once more, then checked against the CPU.
    enqueue_volume_filter(in.data(), median.data(), out.data(), dims, all, config, taps,
                          best_tuning, stream);
    IOCT_CUDA_CHECK(cudaStreamSynchronize(stream));
    std::vector<std::uint8_t> filtered(bytes);
    IOCT_CUDA_CHECK(cudaMemcpy(filtered.data(), out.data(), bytes, cudaMemcpyDeviceToHost));
    std::string cpu_verdict = "not checked";
    if (cpu_check) {
      CpuVolumeFilter cpu(config, 4);
      Volume expected;
      const auto t0 = std::chrono::steady_clock::now();
      cpu.filter_volume(volume, expected);
      const double cpu_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const bool same = std::equal(filtered.begin(), filtered.end(), expected.pixels().begin());
      cpu_verdict = same ? "bit-exact" : "DIFFERENT";
      std::printf("\n  CPU filter (4 threads): %.1f ms; CUDA result %s\n", cpu_ms,
                  cpu_verdict.c_str());
    }
    std::printf("  median variants agree: %s\n", variants_agree ? "yes" : "NO");
    std::printf(
        "\n  median + Gaussian: %.4f ms = %.2f x the device copy of the volume (%.4f ms)"
        "; target 0.15 ms\n",
        combined.median_ms, combined.median_ms / anchor.median_ms, anchor.median_ms);
    std::printf("  device copy: %.0f GB/s (read + write)\n", 2.0 * bytes / anchor.median_ms / 1e6);

    if (!output_median.empty()) write_raw(output_median, reference_median);
    if (!output_filtered.empty()) write_raw(output_filtered, filtered);
    if (!json_path.empty()) {
      nlohmann::json j;
      j["date_utc"] = host_time();
      j["device"] = prop.name;
      j["sms"] = prop.multiProcessorCount;
      j["dims"] = d;
      j["reps"] = reps;
      j["best_median"] = best_median_name;
      j["best_gaussian"] = best_gaussian.name;
      j["cpu_check"] = cpu_verdict;
      j["variants_agree"] = variants_agree;
      for (const Timing& t : timings) {
        j["timings"].push_back({{"name", t.name},
                                {"median_ms", t.median_ms},
                                {"min_ms", t.min_ms},
                                {"max_ms", t.max_ms}});
      }
      std::ofstream(json_path) << j.dump(2) << "\n";
    }
    cudaStreamDestroy(stream);
    return (cpu_verdict == "DIFFERENT" || !variants_agree) ? 1 : 0;
  } catch (const std::exception& e) {
    std::cerr << "ioct-bench-filters: " << e.what() << "\n";
    return 2;
  }
}
