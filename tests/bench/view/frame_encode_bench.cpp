// ioct-bench-frame-encode: how long ioct-gpu's frame publisher takes to JPEG-encode a live render
// (1024 x 768 RGBA, quality 85) cut into N bands on N threads (BandedJpegEncoder on a
// WorkerPool), the choice behind kEncodeBands in gpu/live_stages/src/frame_publisher.cpp.
// Anchor in the same run: a plain copy of the frame's pixels. The picture is render-like (a
// textured retina on a dark background) and encodes to about the size of the live renders.
//
//   ioct-bench-frame-encode --bands 1,2,4,8,12 --frames 200 [--json FILE]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <vector>

#include <nlohmann/json.hpp>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/gpu/live_stages/banded_jpeg_encoder.hpp"
#include "latency_summary.hpp"

namespace {

constexpr std::uint32_t kWidth = 1024, kHeight = 768;

std::vector<std::uint8_t> render_like_picture() {
  std::vector<std::uint8_t> p(std::size_t{kWidth} * kHeight * 4);
  std::mt19937 random(7);
  std::uniform_int_distribution<int> speckle(0, 8);
  for (std::uint32_t y = 0; y < kHeight; ++y) {
    for (std::uint32_t x = 0; x < kWidth; ++x) {
      const double r = std::hypot(x - kWidth / 2.0, (y - kHeight / 2.0) * 1.4);
      int v = 8;
      if (r < 330.0) {
        v = static_cast<int>(110 + 60 * std::sin(x * 0.045) * std::cos(y * 0.03) +
                             40 * std::exp(-std::pow((r - 250.0) / 30.0, 2))) +
            speckle(random);
      }
      std::uint8_t* px = &p[(std::size_t{y} * kWidth + x) * 4];
      px[0] = static_cast<std::uint8_t>(std::clamp(v, 0, 255));
      px[1] = static_cast<std::uint8_t>(std::clamp(v - 25, 0, 255));
      px[2] = static_cast<std::uint8_t>(std::clamp(v / 2, 0, 255));
      px[3] = 255;
    }
  }
  return p;
}

std::string ms(double ns) {
  return ioct::bench::format_ms(ns, 3);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ioct-bench-frame-encode: a live render JPEG-encoded in N bands on N threads"};
  std::vector<unsigned> band_counts{1, 2, 4, 8, 12};
  unsigned frames = 200;
  std::string json_path;
  app.add_option("--bands", band_counts, "band (and thread) counts to measure, in turn")
      ->delimiter(',')
      ->check(CLI::Range(1u, 64u))
      ->capture_default_str();
  app.add_option("--frames", frames, "frames encoded per band count")
      ->check(CLI::Range(10u, 100000u))
      ->capture_default_str();
  app.add_option("--json", json_path, "also write the figures as JSON");
  CLI11_PARSE(app, argc, argv);

  using ioct::gpu::WorkerPool;
  using ioct::gpu::live::BandedJpegEncoder;
  using ioct::gpu::live::PixelLayout;
  const std::vector<std::uint8_t> picture = render_like_picture();
  nlohmann::json runs = nlohmann::json::array();
  std::printf("%ux%u RGBA, quality 85, %u frames each\n", kWidth, kHeight, frames);
  for (const unsigned bands : band_counts) {
    WorkerPool pool(bands);
    BandedJpegEncoder encoder(85, bands, pool);
    std::size_t bytes = encoder.encode(picture, kWidth, kHeight, PixelLayout::rgba).size();
    std::vector<std::uint64_t> times;
    for (unsigned k = 0; k < frames; ++k) {
      const std::uint64_t t0 = ioct::monotonic_ns();
      bytes = encoder.encode(picture, kWidth, kHeight, PixelLayout::rgba).size();
      times.push_back(ioct::monotonic_ns() - t0);
    }
    const auto s = ioct::bench::summarize(times);
    std::printf("%2u bands on %2u threads: p50 %s ms  p99 %s ms  (%zu bytes)\n", bands,
                pool.threads(), ms(s.p50_ns).c_str(), ms(s.p99_ns).c_str(), bytes);
    runs.push_back({{"bands", bands}, {"jpeg_bytes", bytes}, {"encode", ioct::bench::to_json(s)}});
  }
  std::vector<std::uint8_t> copy(picture.size());
  std::vector<std::uint64_t> times;
  for (unsigned k = 0; k < frames; ++k) {
    const std::uint64_t t0 = ioct::monotonic_ns();
    std::memcpy(copy.data(), picture.data(), picture.size());
    times.push_back(ioct::monotonic_ns() - t0);
  }
  const auto anchor = ioct::bench::summarize(times);
  std::printf("anchor: a copy of the frame's pixels p50 %s ms\n", ms(anchor.p50_ns).c_str());
  if (!json_path.empty()) {
    std::ofstream(json_path)
        << nlohmann::json{{"runs", runs}, {"anchor_copy", ioct::bench::to_json(anchor)}}.dump(2)
        << "\n";
  }
  return 0;
}
