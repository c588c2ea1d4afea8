// ioct-bench-view: how old a group is when its frame reaches the viewers of ioct-view, with 1 or
// N viewers on the same machine, against the running appliance (ioct-rt, ioct-gpu, ioct-view).
// Each viewer reads every frame it is sent, measures group published → frame received with
// CLOCK_MONOTONIC (the frame carries the publish time) for the first frame of each group (not
// the group it joined in), and reports "drawn" back as a page does. The groups' figures are also
// split by whether their first frame brought a new B-scan.
// Printed beside the anchor from the same frames: group published → frame rendered by ioct-gpu,
// so the view's own share reads as the difference; and where the time goes, hop by hop, from the
// stamps each frame carries (processed, rendered, written to the frame ring, message made).
//
//   ioct-bench-view --port 8080 --viewers 1,8 --seconds 10 [--json FILE]
#include <CLI/CLI.hpp>
#include <array>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>
#include <vector>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "latency_summary.hpp"
#include "view_client.hpp"

namespace {

using ioct::view::testing::WsViewer;

// The stamps a frame carries after the group's publish time, in order, and the hops between them.
constexpr std::size_t kHops = 5;
constexpr std::array<const char*, kHops - 1> kStampKeys = {"processed_ns", "rendered_ns",
                                                           "written_ns", "made_ns"};
constexpr std::array<const char*, kHops> kHopNames = {
    "published->processed", "processed->rendered", "rendered->written (encode)",
    "written->made (ioct-view)", "made->received (WebSocket)"};

// The latency of a group is that of the first frame showing it; later frames of the same group
// (the view turning between groups) count towards the frame rate only.
struct ViewerFigures {
  std::vector<std::uint64_t> received_ns;  // group published → its first frame received
  std::vector<std::uint64_t> rendered_ns;  // group published → that frame rendered (anchor)
  // received_ns split by what the frame brought: a new B-scan (or tip pair), which ioct-gpu
  // fetches, draws and encodes on the frame's way, or the pictures the viewer already holds.
  std::vector<std::uint64_t> received_new_pictures_ns, received_same_pictures_ns;
  // The same frames' hops: published → processed → rendered → written → made → received.
  std::array<std::vector<std::uint64_t>, kHops> hops;
  std::uint64_t frames = 0;
  std::uint64_t bytes = 0;
};

ViewerFigures watch(std::uint16_t port, double seconds, int own_view) {
  ViewerFigures f;
  std::uint64_t last_group = 0;
  std::uint64_t last_pictures = 0;
  WsViewer viewer(port);
  if (own_view >= 0) {
    // A camera of its own, turning from its own angle: ioct-gpu renders it for this viewer alone.
    viewer.send(
        {{"type", "own_view"},
         {"id", 1},
         {"changes", {{"view", {{"azimuth_deg", 40.0 * own_view}, {"auto_rotate", true}}}}}});
    const auto reply = viewer.next_text("reply", std::chrono::milliseconds(5000));
    if (!reply || !reply->value("ok", false)) {
      std::fprintf(stderr, "ioct-bench-view: own view refused: %s\n",
                   reply ? reply->dump().c_str() : "no reply");
      return f;
    }
  }
  const std::uint64_t end = ioct::monotonic_ns() + static_cast<std::uint64_t>(seconds * 1e9);
  while (ioct::monotonic_ns() < end) {
    auto frame = viewer.next_frame(std::chrono::milliseconds(2000));
    if (!frame) break;
    const std::uint64_t now = ioct::monotonic_ns();
    const std::uint64_t published = frame->description.value("published_ns", std::uint64_t{0});
    ++f.frames;
    f.bytes += frame->render.size() + frame->bscan.size();
    viewer.send({{"type", "drawn"}, {"frame", frame->description["frame"]}});
    const std::uint64_t group = frame->description.value("group", std::uint64_t{0});
    const std::uint64_t pictures = frame->description.value("pictures", std::uint64_t{0});
    const bool new_pictures = pictures != last_pictures;
    last_pictures = pictures;
    // The first frame a viewer gets shows a group published before it connected: its age says
    // when the viewer joined, not how fast a group reaches it.
    const bool first = f.frames == 1;
    if (first || group == last_group) {
      last_group = group;
      continue;
    }
    if (published == 0 || now < published) continue;
    last_group = group;
    f.received_ns.push_back(now - published);
    (new_pictures ? f.received_new_pictures_ns : f.received_same_pictures_ns)
        .push_back(now - published);
    const double rendered_ms = frame->description.value("published_to_rendered_ms", 0.0);
    f.rendered_ns.push_back(static_cast<std::uint64_t>(rendered_ms * 1e6));
    std::array<std::uint64_t, kHops + 1> stamps{published};
    for (std::size_t i = 1; i < kHops; ++i) {
      stamps[i] = frame->description.value(kStampKeys[i - 1], std::uint64_t{0});
    }
    stamps[kHops] = now;
    for (std::size_t i = 0; i < kHops; ++i) {
      if (stamps[i] != 0 && stamps[i + 1] >= stamps[i]) {
        f.hops[i].push_back(stamps[i + 1] - stamps[i]);
      }
    }
  }
  return f;
}

// ioct-gpu's renders so far (all views), from ioct-view's metrics; -1 when unknown.
double gpu_renders(std::uint16_t port) {
  try {
    const std::string text = ioct::view::testing::http_request(port, "GET", "/metrics").body;
    const std::string key = "\nioct_gpu_renders_total ";
    const auto at = text.find(key);
    return at == std::string::npos ? -1.0 : std::stod(text.substr(at + key.size()));
  } catch (const std::exception&) {
    return -1.0;
  }
}

std::string ms(double ns) {
  return ioct::bench::format_ms(ns, 2);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ioct-bench-view: group published -> frame received by 1..N viewers of ioct-view"};
  std::uint16_t port = 8080;
  std::vector<unsigned> viewer_counts{1, 8};
  double seconds = 10.0;
  std::string json_path;
  bool own_views = false;
  app.add_option("--port", port, "ioct-view's port on 127.0.0.1")->capture_default_str();
  app.add_option("--viewers", viewer_counts, "viewer counts to measure, in turn")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--seconds", seconds, "seconds per viewer count")->capture_default_str();
  app.add_option("--json", json_path, "also write the figures as JSON");
  app.add_flag("--own-views", own_views,
               "each viewer orbits a camera of its own (one more render per viewer in ioct-gpu)");
  CLI11_PARSE(app, argc, argv);

  nlohmann::json runs = nlohmann::json::array();
  if (own_views) std::printf("each viewer with a camera of its own\n");
  std::printf("%-8s %8s %10s %10s %10s %10s | %s\n", "viewers", "fps/view", "recv p50", "recv p99",
              "recv max", "MB/s", "anchor: published->rendered p50 / p99 (ms)");
  for (const unsigned n : viewer_counts) {
    const double renders_before = gpu_renders(port);
    std::vector<ViewerFigures> figures(n);
    std::vector<std::thread> threads;
    for (unsigned i = 0; i < n; ++i) {
      threads.emplace_back(
          [&, i] { figures[i] = watch(port, seconds, own_views ? static_cast<int>(i) : -1); });
    }
    for (auto& t : threads) t.join();
    const double renders_per_s = (gpu_renders(port) - renders_before) / seconds;
    std::vector<std::uint64_t> received;
    std::vector<std::uint64_t> rendered;
    std::vector<std::uint64_t> received_new_pictures, received_same_pictures;
    std::array<std::vector<std::uint64_t>, kHops> hops;
    std::uint64_t frames = 0;
    std::uint64_t bytes = 0;
    for (const auto& f : figures) {
      received.insert(received.end(), f.received_ns.begin(), f.received_ns.end());
      rendered.insert(rendered.end(), f.rendered_ns.begin(), f.rendered_ns.end());
      received_new_pictures.insert(received_new_pictures.end(), f.received_new_pictures_ns.begin(),
                                   f.received_new_pictures_ns.end());
      received_same_pictures.insert(received_same_pictures.end(),
                                    f.received_same_pictures_ns.begin(),
                                    f.received_same_pictures_ns.end());
      for (std::size_t i = 0; i < kHops; ++i) {
        hops[i].insert(hops[i].end(), f.hops[i].begin(), f.hops[i].end());
      }
      frames += f.frames;
      bytes += f.bytes;
    }
    if (frames == 0) {
      std::fprintf(stderr, "ioct-bench-view: no frame arrived from 127.0.0.1:%u in %.0f s\n",
                   static_cast<unsigned>(port), seconds);
      return 1;
    }
    const auto r = ioct::bench::summarize(received);
    const auto a = ioct::bench::summarize(rendered);
    const double fps = static_cast<double>(frames) / n / seconds;
    std::printf("ioct-gpu rendered %.1f frames/s (all views) during this run\n", renders_per_s);
    std::printf("%-8u %8.1f %10s %10s %10s %10.1f | %s / %s\n", n, fps, ms(r.p50_ns).c_str(),
                ms(r.p99_ns).c_str(), ms(r.max_ns).c_str(),
                static_cast<double>(bytes) / seconds * 1e-6, ms(a.p50_ns).c_str(),
                ms(a.p99_ns).c_str());
    nlohmann::json by_pictures = nlohmann::json::object();
    for (const auto& [name, samples] :
         {std::pair{"with a new B-scan", &received_new_pictures},
          std::pair{"with the B-scan held", &received_same_pictures}}) {
      if (samples->empty()) continue;
      const auto h = ioct::bench::summarize(*samples);
      std::printf("    received, %-20s p50 %7s  p99 %7s  max %7s ms (%zu groups)\n", name,
                  ms(h.p50_ns).c_str(), ms(h.p99_ns).c_str(), ms(h.max_ns).c_str(),
                  samples->size());
      by_pictures[name] = ioct::bench::to_json(h);
    }
    nlohmann::json hop_figures = nlohmann::json::object();
    for (std::size_t i = 0; i < kHops; ++i) {
      if (hops[i].empty()) continue;
      const auto h = ioct::bench::summarize(hops[i]);
      std::printf("    %-28s p50 %7s  p99 %7s  max %7s ms\n", kHopNames[i], ms(h.p50_ns).c_str(),
                  ms(h.p99_ns).c_str(), ms(h.max_ns).c_str());
      hop_figures[kHopNames[i]] = ioct::bench::to_json(h);
    }
    runs.push_back({{"viewers", n},
                    {"hops", hop_figures},
                    {"published_to_received_by_pictures", by_pictures},
                    {"own_views", own_views},
                    {"gpu_renders_per_s", renders_per_s},
                    {"frames_per_s_per_viewer", fps},
                    {"published_to_received", ioct::bench::to_json(r)},
                    {"anchor_published_to_rendered", ioct::bench::to_json(a)}});
  }
  if (!json_path.empty()) std::ofstream(json_path) << runs.dump(2) << "\n";
  return 0;
}
