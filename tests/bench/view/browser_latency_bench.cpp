// ioct-bench-browser: the browser's share of a frame's age. A frame written to the frame ring ->
// drawn by the surgeon's page in a headless Chromium on the same machine, through ioct-view (in
// this process, as the ioct-view binary runs it) and a WebSocket. The frames are what ioct-gpu
// writes at the default geometry: a 1024 x 768 render and the 688 x 512 B-scan beside it, both
// JPEG, at the display's rate; each shows a new group whose publish time is the moment it is
// written, so ioct-view's own published -> drawn figure (the page reports each frame it drew)
// reads here as written -> drawn. Added to a GPU machine's published -> written (ioct-bench-view),
// it gives group published -> frame drawn in a browser where that machine has no browser.
// Anchor in the same run: written -> sent by ioct-view (its published -> sent). The B-scan is a
// new picture every --bscan-every frames (1: every frame, the worst case; in the appliance it
// changes only with a pass that touched it, 1 or 2 of a volume's 8 groups at the default
// geometry: a few times a second against frames at up to the display's rate).
//
//   ioct-bench-browser [--seconds 30] [--rate 60] [--bscan-every 1] [--json FILE]
#include <unistd.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/devtools/headless_chromium.hpp"
#include "ioct/gpu/live_stages/jpeg_encoder.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "ioct/view_test/http_client.hpp"
#include "line_service.hpp"
#include "operator_token.hpp"
#include "view_server.hpp"

namespace {

namespace fs = std::filesystem;
using namespace ioct;
using namespace std::chrono_literals;

constexpr std::uint32_t kRenderWidth = 1024, kRenderHeight = 768;
constexpr std::uint32_t kBscanWidth = 512, kBscanHeight = 688;  // A-scans x depth px

// Pictures with a render's and a B-scan's structure, and about their JPEG sizes in the live view
// at the default geometry (~65 kB for both together per frame on the H100 host's runs): a smooth
// shaded blob (the render) and speckled layers (the B-scan), `seed` moving them frame to frame.
std::vector<std::uint8_t> render_picture(std::uint32_t seed) {
  const std::uint32_t w = kRenderWidth, h = kRenderHeight;
  std::vector<std::uint8_t> p(std::size_t{w} * h * 4);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      const double r = std::hypot(x - w / 2.0, y - h / 2.0 + 40.0 * std::sin(seed * 0.1));
      const int v = static_cast<int>(200.0 * std::exp(-r * r / (0.08 * w * w)));
      std::uint8_t* px = &p[(std::size_t{y} * w + x) * 4];
      px[0] = static_cast<std::uint8_t>(v);
      px[1] = static_cast<std::uint8_t>(std::min(255, v + 12));
      px[2] = static_cast<std::uint8_t>(std::min(255, v + 24));
      px[3] = 255;
    }
  }
  return p;
}

std::vector<std::uint8_t> bscan_picture(std::uint32_t seed) {
  const std::uint32_t w = kBscanWidth, h = kBscanHeight;  // rows: depth
  std::vector<std::uint8_t> p(std::size_t{w} * h * 3);
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> speckle(0, 90);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      const double top = 250.0 + 30.0 * std::sin(x * 0.012 + seed * 0.1);
      const bool tissue = y > top && y < top + 120.0;
      const int v = tissue ? 60 + speckle(random) : 8;
      std::uint8_t* px = &p[(std::size_t{y} * w + x) * 3];
      px[0] = px[1] = px[2] = static_cast<std::uint8_t>(v);
    }
  }
  return p;
}

// The p50 and p99 of a summary on ioct-view's /metrics, in ms, and its count.
struct Quantiles {
  double p50_ms = NAN, p99_ms = NAN;
  double count = 0;
};

Quantiles summary_of(const std::string& metrics, const std::string& name) {
  Quantiles q;
  const auto value = [&](const std::string& line_start) {
    const auto at = metrics.find(line_start);
    if (at == std::string::npos) return std::nan("");
    return std::strtod(metrics.c_str() + at + line_start.size(), nullptr);
  };
  q.p50_ms = value(name + "{quantile=\"0.5\"} ") * 1e3;
  q.p99_ms = value(name + "{quantile=\"0.99\"} ") * 1e3;
  q.count = value(name + "_count ");
  return q;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"frame written to the frame ring -> drawn by the page in a headless Chromium"};
  double seconds = 30.0;
  double rate_hz = 60.0;
  std::string json_path;
  app.add_option("--seconds", seconds, "measured time")->check(CLI::Range(1.0, 3600.0));
  app.add_option("--rate", rate_hz, "frames (groups) per second")->check(CLI::Range(1.0, 240.0));
  std::uint32_t bscan_every = 1;
  app.add_option("--bscan-every", bscan_every, "frames that show the same B-scan picture")
      ->check(CLI::Range(1u, 1000u));
  app.add_option("--json", json_path, "write the figures here too");
  CLI11_PARSE(app, argc, argv);

  const fs::path dir =
      fs::temp_directory_path() / ("ioct-bench-browser-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string frames_name = "ioct-bench-browser-" + std::to_string(::getpid()) + ".frames";
  try {
    // ioct-gpu's view socket and ioct-rt's control socket, as stand-ins that say "all is well".
    const nlohmann::json params = {{"mode", "enhanced"}};
    view::testing::LineService gpu((dir / "gpu.sock").string(), [&](const nlohmann::json& r) {
      if (r.value("cmd", "") == "get") {
        return nlohmann::json{{"ok", true}, {"generation", 1}, {"params", params}};
      }
      return nlohmann::json{{"ok", true}, {"generation", 1}};
    });
    view::testing::LineService rt((dir / "rt.sock").string(), [](const nlohmann::json& r) {
      if (r.value("cmd", "") == "status") {
        return nlohmann::json{
            {"ok", true},
            {"status", {{"state", "scanning"}, {"safety", nlohmann::json::object()}}}};
      }
      return nlohmann::json{{"ok", true}};
    });
    shm::FrameRingConfig ring;
    ring.name = frames_name;
    shm::FrameRingWriter writer(ring);
    {
      std::ofstream token(dir / "token");
      token << "bench-token-0123456789abcdef\n";
    }
    fs::permissions(dir / "token", fs::perms::owner_read | fs::perms::owner_write);
    view::ViewConfig config;
    config.port = 0;
    config.frames = frames_name;
    config.view_socket = dir / "gpu.sock";
    config.control_socket = dir / "rt.sock";
    config.www_dir = IOCT_VIEW_WWW_DIR;
    config.state_dir = dir / "state";
    view::ViewServer server(config, view::OperatorToken::read(dir / "token"));
    const unsigned short port = server.port();
    std::thread server_thread([&] { server.run(); });

    // Frames: a few pictures encoded once, cycled, so the writer costs what a copy costs.
    gpu::live::JpegEncoder render_encoder(85), bscan_encoder(90);
    std::vector<std::vector<std::byte>> renders, bscans;
    for (std::uint32_t k = 0; k < 8; ++k) {
      const auto r = render_encoder.encode(render_picture(k), kRenderWidth, kRenderHeight,
                                           gpu::live::PixelLayout::rgba);
      renders.emplace_back(r.begin(), r.end());
      const auto b = bscan_encoder.encode(bscan_picture(100 + k), kBscanWidth, kBscanHeight,
                                          gpu::live::PixelLayout::rgb);
      bscans.emplace_back(b.begin(), b.end());
    }
    std::atomic<bool> measuring{false}, stop{false};
    std::atomic<std::uint64_t> written{0};
    std::thread publisher([&] {
      const auto period = std::chrono::duration<double>(1.0 / rate_hz);
      auto next = std::chrono::steady_clock::now();
      std::uint64_t group = 0;
      for (std::uint64_t f = 0; !stop.load(); ++f) {
        // Until measuring, every frame shows group 0: ioct-view counts a group's first frame
        // drawn only, so the page's warm-up adds one sample.
        if (measuring.load()) ++group;
        const std::uint64_t now = monotonic_ns();
        shm::FrameRingStatus status{};
        status.source_state = static_cast<std::uint64_t>(shm::SourceState::live);
        status.groups_consumed = group + 1;
        status.last_group_index = group;
        status.last_group_published_ns = now;
        status.group_period_ns = static_cast<std::uint64_t>(1e9 / rate_hz);
        writer.set_status(status);
        shm::FrameMeta m{};
        m.group_index = group;
        m.volume_index = group / 8;
        m.params_generation = 1;
        m.t_group_published_ns = now;
        m.t_group_processed_ns = now;
        m.t_rendered_ns = now;
        m.format = static_cast<std::uint32_t>(shm::FrameFormat::jpeg);
        m.width = kRenderWidth;
        m.height = kRenderHeight;
        m.bscan_width = kBscanWidth;
        m.bscan_height = kBscanHeight;
        m.bscan_index = 64;
        m.bscans = 128;
        std::strncpy(m.mode, "enhanced", sizeof m.mode - 1);
        writer.publish(m, renders[f % renders.size()], bscans[(f / bscan_every) % bscans.size()]);
        written.fetch_add(1);
        next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
        std::this_thread::sleep_until(next);
      }
    });

    devtools::ChromiumOptions browser_options;
    browser_options.window_width = 1920;
    browser_options.window_height = 1080;
    browser_options.log_file = dir / "chromium.log";
    devtools::HeadlessChromium browser(browser_options);
    const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
    auto page = browser.open_page(url);
    const auto live = page->wait_until(
        "window.ioctView && ioctView.status.signal === 'live' && ioctView.status.framesDrawn >= 30",
        30s);
    if (!live) {
      std::fprintf(stderr, "ioct-bench-browser: the page never drew live frames (%s)\n",
                   browser.log_tail(800).c_str());
      stop = true;
      publisher.join();
      server.stop();
      server_thread.join();
      fs::remove_all(dir);
      return 2;
    }
    const nlohmann::json drawn_before = page->evaluate("ioctView.status.framesDrawn", 5s);
    const std::uint64_t written_before = written.load();
    measuring = true;
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const nlohmann::json drawn_after = page->evaluate("ioctView.status.framesDrawn", 5s);
    const std::uint64_t written_after = written.load();
    const std::string metrics = view_test::http_request(port, "GET", "/metrics").body;
    stop = true;
    publisher.join();
    server.stop();
    server_thread.join();

    const Quantiles drawn = summary_of(metrics, "ioct_view_published_to_drawn_seconds");
    const Quantiles sent = summary_of(metrics, "ioct_view_published_to_sent_seconds");
    const double frames_written = static_cast<double>(written_after - written_before);
    const double frames_drawn = drawn_after.get<double>() - drawn_before.get<double>();
    std::printf(
        "frames: %.0f written, %.0f drawn by the page (%.1f /s) in %.0f s; render %ux%u %zu B, "
        "B-scan %ux%u %zu B (JPEG), a new B-scan every %u frames\n",
        frames_written, frames_drawn, frames_drawn / seconds, seconds, kRenderWidth, kRenderHeight,
        renders[0].size(), kBscanWidth, kBscanHeight, bscans[0].size(), bscan_every);
    std::printf("written -> drawn in the page: p50 %.2f ms, p99 %.2f ms (%.0f groups)\n",
                drawn.p50_ms, drawn.p99_ms, drawn.count);
    std::printf("anchor, written -> sent by ioct-view: p50 %.2f ms, p99 %.2f ms\n", sent.p50_ms,
                sent.p99_ms);
    if (!json_path.empty()) {
      std::ofstream(json_path) << nlohmann::json{{"seconds", seconds},
                                                 {"rate_hz", rate_hz},
                                                 {"bscan_every", bscan_every},
                                                 {"frames_written", frames_written},
                                                 {"frames_drawn", frames_drawn},
                                                 {"render_jpeg_bytes", renders[0].size()},
                                                 {"bscan_jpeg_bytes", bscans[0].size()},
                                                 {"written_to_drawn_ms",
                                                  {{"p50", drawn.p50_ms},
                                                   {"p99", drawn.p99_ms},
                                                   {"count", drawn.count}}},
                                                 {"written_to_sent_ms",
                                                  {{"p50", sent.p50_ms}, {"p99", sent.p99_ms}}}}
                                      .dump(2)
                               << "\n";
    }
    fs::remove_all(dir);
    return std::isfinite(drawn.p99_ms) && drawn.count > 1 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ioct-bench-browser: %s\n", e.what());
    fs::remove_all(dir);
    return 2;
  }
}
