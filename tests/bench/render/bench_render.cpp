// ioct-bench-render: frame times of the CUDA renderer in the papers' setups, beside anchors
// measured in the same run (the plain ray caster of the same binary, a device-to-device copy).
//   Weiss et al. 2019: a 512 x 512 x 128 volume rendered at 1024 x 1024 over one full turn
//     (360 frames, 1 deg apart) at 25 deg inclination: mean and p99 per mode.
//   Viehland et al. 2016: a 512 x 688 x 128 volume rendered at 425 x 600, mono and stereo.
// The volumes are the synthetic layered retina of the tests (a needle above it), so most rays
// cross empty vitreous first, as in the papers' data.
#include <CLI/CLI.hpp>

#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "analytic_volumes.hpp"
#include "device_timing.hpp"
#include "ioct/gpu/render/cuda_renderer.hpp"

namespace {

using namespace ioct::gpu;
using namespace ioct::gpu::render;

struct Stats {
  double mean_ms = 0, p99_ms = 0, max_ms = 0;
};

// `before(f)`, if given, runs before frame f outside the timed span (e.g. a group update).
Stats frame_times(CudaRenderer& renderer, RenderConfig config, int frames,
                  const std::function<void(int)>& before = {}) {
  auto stream = static_cast<cudaStream_t>(renderer.stream());
  const double azimuth0 = config.view.azimuth_deg;
  renderer.render_on_device(config);  // warm-up: tables, caches
  renderer.synchronize();
  std::vector<double> ms;
  for (int f = 0; f < frames; ++f) {
    config.view.azimuth_deg = azimuth0 + 360.0 * f / frames;
    if (before) {
      before(f);
      renderer.synchronize();
    }
    ms.push_back(ioct::bench::device_ms(stream, [&] { renderer.render_on_device(config); }));
  }
  Stats s;
  for (const double t : ms) s.mean_ms += t;
  s.mean_ms /= static_cast<double>(ms.size());
  std::sort(ms.begin(), ms.end());
  s.p99_ms = ms[static_cast<std::size_t>(0.99 * static_cast<double>(ms.size() - 1))];
  s.max_ms = ms.back();
  return s;
}

double device_copy_gb_per_s(std::size_t bytes) {
  ioct::gpu::cuda::DeviceArray<std::byte> a(bytes), b(bytes);
  IOCT_CUDA_CHECK(cudaMemset(a.data(), 1, bytes));
  IOCT_CUDA_CHECK(cudaMemcpy(b.data(), a.data(), bytes, cudaMemcpyDeviceToDevice));
  const int reps = 20;
  const double ms = ioct::bench::device_ms(nullptr, [&] {
    for (int i = 0; i < reps; ++i) {
      IOCT_CUDA_CHECK(cudaMemcpy(b.data(), a.data(), bytes, cudaMemcpyDeviceToDevice));
    }
  });
  // A copy reads and writes every byte.
  return 2.0 * static_cast<double>(bytes) * reps / (ms * 1e-3) / 1e9;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 360;
  std::string json_path;
  CLI::App app{"ioct-bench-render: CUDA render frame times in the papers' setups"};
  app.add_option("--frames", frames, "frames per full turn (the paper: 360)");
  app.add_option("--json", json_path, "also write the figures as JSON here");
  CLI11_PARSE(app, argc, argv);

  try {
    cudaDeviceProp prop{};
    IOCT_CUDA_CHECK(cudaGetDeviceProperties(&prop, 0));
    std::printf("device: %s\n", prop.name);
    const double copy = device_copy_gb_per_s(std::size_t{512} << 20);
    std::printf("anchor: device-to-device copy %.0f GB/s (read + write, 512 MiB)\n", copy);
    std::string json = "{\n  \"device\": \"" + std::string(prop.name) +
                       "\",\n  \"device_copy_gb_per_s\": " + std::to_string(copy) + ",\n";

    // Weiss et al.: 512 x 512 x 128 -> 1024 x 1024, one full turn.
    {
      auto retina = ioct::render_test::make_synthetic_retina(128, 512, 512);
      CudaRenderer renderer;
      const auto upload_start = std::chrono::steady_clock::now();
      renderer.set_volume(retina.volume, &retina.surfaces);
      const double upload_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - upload_start)
              .count();
      const auto group_start = std::chrono::steady_clock::now();
      const int groups = 8;
      for (int g = 0; g < groups; ++g) {
        renderer.update_bscans(retina.volume, static_cast<std::uint32_t>(16 * g), 16,
                               &retina.surfaces);
      }
      const double group_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - group_start)
              .count() /
          groups;
      std::printf(
          "\n512x512x128 (B-scans 128, A-scans 512, depth 512) -> 1024x1024, %d frames "
          "over 360 deg, 25 deg inclination\n",
          frames);
      std::printf(
          "  whole volume from the host %.2f ms; one group of 16 B-scans from the host "
          "(texture, bricks, centre of mass, reference) %.3f ms\n",
          upload_ms, group_ms);
      RenderConfig base;
      base.view.output_width = 1024;
      base.view.output_height = 1024;
      base.view.elevation_deg = 25.0;
      struct Case {
        const char* name;
        RenderMode mode;
        std::uint32_t shadow_steps;
        const char* paper;
        bool new_group_each_frame =
            false;  // the live case: the volume changed since the last frame
      };
      const Case cases[] = {
          {"basic (anchor: plain ray caster)", RenderMode::basic, 0, "-"},
          {"enhanced (Viehland)", RenderMode::enhanced, 0, "4.6 ms"},
          {"axial colorization", RenderMode::axial_colorization, 0, "5.6 ms"},
          {"layer-aware, no shadows", RenderMode::layer_aware, 0, "4.5 ms"},
          {"layer-aware N_s=20", RenderMode::layer_aware, 20, "8.6 ms"},
          {"layer-aware N_s=200", RenderMode::layer_aware, 200, "31.1 ms"},
          {"LA-MIP composite, new group each frame", RenderMode::la_mip_composite, 0, "1.1 ms",
           true},
          {"LA-MIP composite, same volume", RenderMode::la_mip_composite, 0, "1.1 ms"},
      };
      json += "  \"weiss_512x512x128_to_1024x1024\": {\n    \"upload_volume_ms\": " +
              std::to_string(upload_ms) +
              ",\n    \"update_group_ms\": " + std::to_string(group_ms) + ",\n    \"modes\": [\n";
      bool first = true;
      for (const Case& c : cases) {
        RenderConfig config = base;
        config.mode = c.mode;
        config.layer_aware.shadow_steps = c.shadow_steps;
        const auto update_group = [&](int f) {
          renderer.update_bscans(retina.volume, static_cast<std::uint32_t>(16 * (f % groups)), 16,
                                 &retina.surfaces);
        };
        const Stats s = c.new_group_each_frame ? frame_times(renderer, config, frames, update_group)
                                               : frame_times(renderer, config, frames);
        std::printf("  %-40s mean %7.3f ms  p99 %7.3f ms  max %7.3f ms   (Titan Xp: %s)\n", c.name,
                    s.mean_ms, s.p99_ms, s.max_ms, c.paper);
        json += std::string(first ? "" : ",\n") + "      {\"mode\": \"" + c.name +
                "\", \"mean_ms\": " + std::to_string(s.mean_ms) +
                ", \"p99_ms\": " + std::to_string(s.p99_ms) +
                ", \"max_ms\": " + std::to_string(s.max_ms) + "}";
        first = false;
      }
      json += "\n    ]\n  },\n";
    }

    // Viehland et al.: 512 x 688 x 128 -> 425 x 600, mono and stereo.
    {
      auto retina = ioct::render_test::make_synthetic_retina(128, 512, 688);
      CudaRenderer renderer;
      renderer.set_volume(retina.volume, &retina.surfaces);
      RenderConfig config;
      config.view.output_width = 425;
      config.view.output_height = 600;
      std::printf("\n512x688x128 -> 425x600 (Viehland), %d frames over 360 deg\n", frames);
      json += "  \"viehland_512x688x128_to_425x600\": {\n";
      double mono_mean = 0;
      for (const RenderMode mode : {RenderMode::basic, RenderMode::enhanced}) {
        for (const bool stereo : {false, true}) {
          config.mode = mode;
          config.view.stereo = stereo;
          const Stats s = frame_times(renderer, config, frames);
          if (mode == RenderMode::enhanced && !stereo) mono_mean = s.mean_ms;
          std::printf(
              "  %-9s %-6s mean %7.3f ms  p99 %7.3f ms%s\n", std::string(to_string(mode)).c_str(),
              stereo ? "stereo" : "mono", s.mean_ms, s.p99_ms,
              mode == RenderMode::enhanced && stereo
                  ? (" (stereo / mono " + std::to_string(s.mean_ms / mono_mean) + ")").c_str()
                  : "");
          json += "    \"" + std::string(to_string(mode)) + (stereo ? "_stereo" : "_mono") +
                  "\": {\"mean_ms\": " + std::to_string(s.mean_ms) +
                  ", \"p99_ms\": " + std::to_string(s.p99_ms) + "},\n";
        }
      }
      json +=
          "    \"paper\": \"enhanced 2.5 ms, basic 0.7 ms, stereo +2.5 ms (GTX Titan Black)\"\n  "
          "}\n}\n";
    }
    if (!json_path.empty()) std::ofstream(json_path) << json;
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ioct-bench-render: %s\n", e.what());
    return 1;
  }
}
