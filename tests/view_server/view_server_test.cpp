// ioct-view end to end without a browser: a frame ring written here, stand-ins for ioct-gpu's
// view socket and ioct-rt's control socket, and Beast clients as browsers.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <thread>

#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/shm/frame_ring.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "line_service.hpp"
#include "view_client.hpp"
#include "view_server.hpp"

namespace ioct::view {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::http_request;
using testing::LineService;
using testing::ReceivedFrame;
using testing::WsViewer;

constexpr const char* kToken = "test-operator-token-0123456789";

class ViewServerTest : public ::testing::Test {
 protected:
  void start(std::uint32_t max_connections = 64) {
    dir_ = fs::temp_directory_path() /
           ("ioct-view-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
    fs::create_directories(dir_ / "www");
    std::ofstream(dir_ / "www" / "index.html") << "<p>surgeon";
    {
      std::ofstream token(dir_ / "token");
      token << kToken << "\n";
    }
    fs::permissions(dir_ / "token", fs::perms::owner_read | fs::perms::owner_write);

    params_ = {{"mode", "enhanced"}, {"enhanced", {{"threshold", 0.35}}}};
    gpu_ = std::make_unique<LineService>((dir_ / "gpu.sock").string(),
                                         [this](const nlohmann::json& r) { return gpu_reply(r); });
    rt_ =
        std::make_unique<LineService>((dir_ / "rt.sock").string(), [this](const nlohmann::json& r) {
          if (r.value("cmd", "") == "status") {
            if (odd_replies_) return nlohmann::json{{"ok", "yes"}, {"status", "scanning"}};
            return nlohmann::json{{"ok", true},
                                  {"status",
                                   {{"state", "scanning"},
                                    {"acquisition", {{"groups_published", 5}}},
                                    {"safety", safety_status()}}}};
          }
          // A command to ioct-rt that takes its time (the polls wait behind it).
          std::this_thread::sleep_for(std::chrono::milliseconds(rt_command_delay_ms_.load()));
          return nlohmann::json{{"ok", true}, {"cmd", r.value("cmd", "")}};
        });
    writer_ = std::make_unique<shm::FrameRingWriter>(frame_config());

    ViewConfig config;
    config.port = 0;
    config.frames = frames_.str();
    config.view_socket = dir_ / "gpu.sock";
    config.control_socket = dir_ / "rt.sock";
    config.www_dir = dir_ / "www";
    config.state_dir = dir_ / "state";
    config.max_connections = max_connections;
    config.max_connections_per_address = max_connections_per_address_;
    config.backend_timeout_s = backend_timeout_s_;
    config.rt_status_interval_s = 0.1;
    config_ = config;
    start_server();
  }

  void start_server() {
    server_ = std::make_unique<ViewServer>(config_, OperatorToken::read(dir_ / "token"));
    port_ = server_->port();
    thread_ = std::thread([this] { server_->run(); });
  }

  void stop_server() {
    server_->stop();
    thread_.join();
    server_.reset();
  }

  void TearDown() override {
    if (server_) stop_server();
    writer_.reset();
    gpu_.reset();
    rt_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }

  shm::FrameRingConfig frame_config() const {
    shm::FrameRingConfig c;
    c.name = frames_.str();
    c.slots = 8;
    c.max_payload_bytes = 1 << 20;
    return c;
  }

  nlohmann::json gpu_reply(const nlohmann::json& r) {
    const std::string cmd = r.value("cmd", "");
    if (cmd == "get" && odd_replies_) return {{"ok", true}, {"generation", "1"}, {"params", 7}};
    if (cmd == "get")
      return {{"ok", true}, {"generation", generation_.load()}, {"params", params_}};
    if (cmd == "set") {
      const auto& changes = r["changes"];
      if (changes.contains("enhanced") && changes["enhanced"].value("threshold", 0.0) > 1.0) {
        return {{"ok", false},
                {"error", "render.enhanced.threshold = 2: must be in [0, 1]"},
                {"key", "render.enhanced.threshold"}};
      }
      if (!r.contains("view")) {
        params_.merge_patch(changes);
        ++generation_;
      }
      return {{"ok", true}, {"generation", generation_.load()}};
    }
    if (cmd == "snapshot") {
      // ioct-gpu answers once the next full-size render is done: seconds on the CPU renderer.
      std::this_thread::sleep_for(std::chrono::milliseconds(snapshot_delay_ms_.load()));
      return {{"ok", true}, {"png", "/snapshots/s.png"}, {"json", "/snapshots/s.json"}};
    }
    return {{"ok", true}};
  }
  std::atomic<int> snapshot_delay_ms_{0};
  std::atomic<int> rt_command_delay_ms_{0};
  std::uint32_t max_connections_per_address_ = 64;
  double backend_timeout_s_ = 0.5;
  // The stand-ins answer with fields of the wrong type (another version, another service).
  std::atomic<bool> odd_replies_{false};

  // The pipeline as ioct-gpu reports it: live, newest group published `age` ago.
  void report_live(std::uint64_t group, std::chrono::nanoseconds age = 0ns) {
    shm::FrameRingStatus s{};
    s.source_state = static_cast<std::uint64_t>(shm::SourceState::live);
    s.groups_consumed = group + 1;
    s.last_group_index = group;
    s.last_group_published_ns = ioct::monotonic_ns() - static_cast<std::uint64_t>(age.count());
    s.group_period_ns = 86'000'000;
    writer_->set_status(s);
    writer_->heartbeat(ioct::monotonic_ns());
  }

  void publish(std::uint64_t group, std::uint64_t view = 0, std::size_t render_bytes = 1000,
               std::byte bscan_value = std::byte{7}) {
    report_live(group);
    shm::FrameMeta m{};
    m.group_index = group;
    m.view_id = view;
    m.t_group_published_ns = ioct::monotonic_ns();
    m.format = static_cast<std::uint32_t>(shm::FrameFormat::jpeg);
    m.width = 64;
    m.height = 48;
    std::strncpy(m.mode, "enhanced", sizeof m.mode - 1);
    const std::vector<std::byte> render(render_bytes, static_cast<std::byte>(group & 0xff));
    const std::vector<std::byte> bscan(100, bscan_value);
    writer_->publish(m, render, bscan);
  }

  // Polls /api/state until `pred` holds or 3 s pass. `refresh`, when given, runs before each
  // poll, as a live ioct-gpu reports every group: a state that holds only while the newest group
  // is young (live) must not depend on this thread's timing.
  nlohmann::json state_when(const std::function<bool(const nlohmann::json&)>& pred,
                            const std::function<void()>& refresh = {}) {
    nlohmann::json state;
    for (int i = 0; i < 150; ++i) {
      if (refresh) refresh();
      state = http_request(port_, "GET", "/api/state").json();
      if (pred(state)) return state;
      std::this_thread::sleep_for(20ms);
    }
    return state;
  }

  test_support::ScopedShmName frames_{"view-frames"};
  fs::path dir_;
  static inline int counter_ = 0;
  nlohmann::json params_;
  std::atomic<std::uint64_t> generation_{1};
  std::atomic<bool> footswitch_{false};
  // ioct-rt's own count of presses; negative: an ioct-rt that does not report one.
  std::atomic<long> footswitch_presses_{-1};
  nlohmann::json safety_status() const {
    nlohmann::json safety = {{"inputs", {{"footswitch", footswitch_.load()}}}};
    if (footswitch_presses_ >= 0) safety["footswitch_presses"] = footswitch_presses_.load();
    return safety;
  }
  std::unique_ptr<LineService> gpu_;
  std::unique_ptr<LineService> rt_;
  std::unique_ptr<shm::FrameRingWriter> writer_;
  ViewConfig config_;
  std::unique_ptr<ViewServer> server_;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

// A sample without labels of ioct-view's /metrics, asked from `from`; nullopt when it is not there.
std::optional<double> metric(std::uint16_t port, const std::string& name,
                             const std::string& from = "127.0.0.1") {
  const std::string metrics = http_request(port, "GET", "/metrics", {}, {}, from).body;
  const std::size_t at = metrics.find("\n" + name + " ");
  if (at == std::string::npos) return std::nullopt;
  return std::stod(metrics.substr(at + name.size() + 2));
}

std::size_t count_cmd(const std::vector<nlohmann::json>& requests, const std::string& cmd) {
  return static_cast<std::size_t>(std::count_if(
      requests.begin(), requests.end(), [&](auto& r) { return r.value("cmd", "") == cmd; }));
}

TEST_F(ViewServerTest, StateIsLiveWithTheParametersAndTheScanStatus) {
  start();
  const auto state = state_when(
      [](const nlohmann::json& s) {
        return s.value("signal", "") == "live" && s["params"].is_object() && s["rt"].is_object();
      },
      [&] { report_live(3); });
  EXPECT_EQ(state["signal"], "live");
  EXPECT_EQ(state["params"]["mode"], "enhanced");
  EXPECT_EQ(state["rt"]["state"], "scanning");
  EXPECT_EQ(state["role"], "viewer");
  EXPECT_NEAR(state["groups_per_s"].get<double>(), 1e9 / 86e6, 1e-6);
}

// ioct-rt's status says how old it is: a poll waits behind the operators' commands to ioct-rt, so
// while slow commands hold that lane (five of 400 ms) the state's rt_age_ms grows (the page then
// shows the scanner and the laser as unknown, state-line.js), and it is fresh again once they are
// done.
TEST_F(ViewServerTest, TheScannersStatusSaysHowOldItIs) {
  backend_timeout_s_ = 5.0;  // the slow commands below are answered, however loaded the machine
  start();
  const auto age = [](const nlohmann::json& s) {
    return s["rt_age_ms"].is_number() ? s["rt_age_ms"].get<double>() : -1.0;
  };
  const auto fresh = state_when([](const nlohmann::json& s) { return s["rt"].is_object(); });
  EXPECT_GE(age(fresh), 0.0) << fresh.dump();
  EXPECT_LT(age(fresh), 1000.0) << fresh.dump();
  rt_command_delay_ms_ = 400;
  std::vector<std::thread> operators;
  for (int i = 0; i < 5; ++i) {
    operators.emplace_back(
        [&] { http_request(port_, "POST", "/api/scan", R"({"cmd":"start"})", kToken); });
  }
  const auto old = state_when([&](const nlohmann::json& s) { return age(s) > 1000.0; });
  EXPECT_GT(age(old), 1000.0) << old.dump();
  EXPECT_EQ(old["rt"]["state"], "scanning") << "the last status, with its age";
  for (std::thread& t : operators) t.join();
  rt_command_delay_ms_ = 0;
  const auto again =
      state_when([&](const nlohmann::json& s) { return age(s) >= 0 && age(s) < 500; });
  EXPECT_LT(age(again), 500.0) << again.dump();
}

TEST_F(ViewServerTest, StaleAfterThreeGroupPeriodsAndNoSignalWhenTheWriterGoes) {
  start();
  // 3 x 86 ms = 258 ms: the newest group 300 ms old, the heartbeat kept fresh.
  auto state = state_when([](const nlohmann::json& s) { return s["signal"] == "stale"; },
                          [&] { report_live(3, 300ms); });
  EXPECT_EQ(state["signal"], "stale");
  EXPECT_GE(state["age_ms"].get<double>(), 300.0);

  report_live(3, 300ms);  // its heartbeat fresh: the writer is alive until it goes below
  WsViewer viewer(port_);
  writer_.reset();  // ioct-gpu gone
  // Until the push that says so: a slow join may first see the writer as not responding.
  const auto gone = [](const nlohmann::json& s) {
    return s.value("signal", "") == "no_signal" &&
           s.value("reason", "") == "ioct-gpu is not running";
  };
  auto pushed = viewer.next_text("state", 2s);
  while (pushed && !gone(*pushed)) pushed = viewer.next_text("state", 2s);
  ASSERT_TRUE(pushed) << "the page must be told NO SIGNAL, ioct-gpu is not running, unasked";

  writer_ = std::make_unique<shm::FrameRingWriter>(frame_config());  // ioct-gpu back
  publish(10);
  state = state_when([](const nlohmann::json& s) { return s["signal"] == "live"; },
                     [&] { report_live(10); });
  EXPECT_EQ(state["signal"], "live");
  auto frame = viewer.next_frame(2s);
  ASSERT_TRUE(frame) << "frames flow again after ioct-gpu restarted";
  EXPECT_EQ(frame->description["group"], 10);
}

TEST_F(ViewServerTest, EightViewersKeepTheirFramesWhileANinthNeverReads) {
  start();
  WsViewer idle(port_);  // connected, never reads
  std::vector<std::unique_ptr<WsViewer>> viewers;
  for (int i = 0; i < 8; ++i) viewers.push_back(std::make_unique<WsViewer>(port_));
  // Each has joined once its first state arrived; the idle one reads that and nothing more.
  ASSERT_TRUE(idle.next_text("state", 2s)) << "joined";
  for (auto& v : viewers) ASSERT_TRUE(v->next_text("state", 2s)) << "joined";
  constexpr std::uint64_t kFrames = 40;
  for (std::uint64_t g = 0; g < kFrames; ++g) {
    publish(g, 0, 400'000);  // large frames, so the idle viewer's socket fills up
    std::this_thread::sleep_for(5ms);
  }
  for (auto& v : viewers) {
    std::uint64_t last = 0;
    bool any = false;
    while (auto frame = v->next_frame(3s)) {
      const std::uint64_t g = frame->description["group"];
      if (any) {
        EXPECT_GT(g, last) << "a viewer gets newer frames only";
      }
      // Every frame has the same B-scan: the first brings it, the others say it repeats.
      EXPECT_EQ(frame->description.value("pictures_repeated", false), any) << "group " << g;
      EXPECT_EQ(frame->bscan.size(), any ? 0u : 100u) << "group " << g;
      last = g;
      any = true;
      EXPECT_EQ(frame->render.size(), 400'000u);
      EXPECT_EQ(static_cast<unsigned char>(frame->render[0]), g & 0xff);
      if (g == kFrames - 1) break;
    }
    EXPECT_EQ(last, kFrames - 1) << "every reading viewer reaches the newest frame";
  }
  EXPECT_GT(metric(port_, "ioct_view_frames_replaced_total").value_or(0.0), 0.0)
      << "the idle viewer's frames were replaced, not queued";
}

// The B-scan beside the render is sent to a viewer only when it is not the one that viewer was
// sent last (ioct-gpu writes it with every frame, new only after a pass that touched it): the
// frames between say "pictures_repeated" and carry the render alone; a viewer who joins later is
// sent the B-scan with its first frame.
TEST_F(ViewServerTest, TheBscanGoesToAViewerOnlyWhenItIsNewToIt) {
  start();
  WsViewer first(port_);
  ASSERT_TRUE(first.next_text("state", 2s)) << "joined";
  const auto frame_of = [&](WsViewer& viewer, std::uint64_t group, std::byte bscan) {
    publish(group, 0, 1000, bscan);
    auto frame = viewer.next_frame(3s);
    EXPECT_TRUE(frame.has_value()) << "group " << group;
    if (frame) {
      EXPECT_EQ(frame->description.at("group"), group);
    }
    return frame.value_or(ReceivedFrame{});
  };
  const std::byte a{7}, b{9};
  ReceivedFrame f = frame_of(first, 0, a);
  EXPECT_EQ(f.bscan, std::string(100, '\x07'));
  EXPECT_FALSE(f.description.value("pictures_repeated", false));
  for (std::uint64_t g = 1; g <= 2; ++g) {
    const nlohmann::json named = f.description.at("pictures");
    f = frame_of(first, g, a);
    EXPECT_EQ(f.description.at("pictures"), named) << "it names the pictures it repeats";
    EXPECT_TRUE(f.bscan.empty()) << "group " << g;
    EXPECT_TRUE(f.description.value("pictures_repeated", false)) << "group " << g;
    EXPECT_EQ(f.description.at("bscan_bytes"), 0);
    EXPECT_EQ(f.description.at("render_bytes"), 1000) << "the rest of the description as it was";
    EXPECT_EQ(f.render.size(), 1000u);
  }
  const std::uint64_t pictures_a = f.description.at("pictures");
  f = frame_of(first, 3, b);
  EXPECT_EQ(f.bscan, std::string(100, '\x09')) << "a new B-scan comes whole";
  EXPECT_FALSE(f.description.value("pictures_repeated", false));
  EXPECT_NE(f.description.at("pictures"), pictures_a) << "new pictures, a new number";
  f = frame_of(first, 4, b);
  EXPECT_TRUE(f.description.value("pictures_repeated", false));

  WsViewer later(port_);
  ASSERT_TRUE(later.next_text("state", 2s)) << "joined";
  f = frame_of(later, 5, b);
  EXPECT_EQ(f.bscan, std::string(100, '\x09')) << "a viewer's first frame brings the B-scan";
  EXPECT_FALSE(f.description.value("pictures_repeated", false));
  f = first.next_frame(3s).value_or(ReceivedFrame{});
  EXPECT_TRUE(f.description.value("pictures_repeated", false)) << "the first viewer has it";
}

TEST_F(ViewServerTest, OnlyOperatorsChangeTheRenderAndTheirErrorsNameTheKey) {
  start();
  const std::string change = R"({"enhanced":{"threshold":0.5}})";
  EXPECT_EQ(http_request(port_, "POST", "/api/params", change).status, 401u);
  EXPECT_EQ(http_request(port_, "POST", "/api/params", change, "wrong-token-0000000").status, 401u);
  WsViewer viewer(port_);
  viewer.send({{"type", "params"}, {"id", 1}, {"changes", {{"enhanced", {{"threshold", 0.5}}}}}});
  auto reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ((*reply)["status"], 401);
  viewer.send({{"type", "hello"}, {"id", 2}, {"token", "not-the-token-000000"}});
  reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ((*reply)["ok"], false);
  EXPECT_EQ(count_cmd(gpu_->requests(), "set"), 0u) << "nothing reached ioct-gpu";

  const auto ok = http_request(port_, "POST", "/api/params", change, kToken);
  EXPECT_EQ(ok.status, 200u) << ok.body;
  const auto bad =
      http_request(port_, "POST", "/api/params", R"({"enhanced":{"threshold":2}})", kToken);
  EXPECT_EQ(bad.status, 400u);
  EXPECT_EQ(bad.json()["key"], "render.enhanced.threshold");

  viewer.send({{"type", "hello"}, {"id", 3}, {"token", kToken}});
  reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ((*reply)["role"], "operator");
  viewer.send({{"type", "params"}, {"id", 4}, {"changes", {{"mode", "layer-aware"}}}});
  reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ((*reply)["ok"], true);
  EXPECT_EQ(count_cmd(gpu_->requests(), "set"), 3u);
  const auto state = state_when([](const nlohmann::json& s) {
    return s["params"].is_object() && s["params"]["mode"] == "layer-aware";
  });
  EXPECT_EQ(state["params"]["mode"], "layer-aware") << "the state follows the change";
  EXPECT_TRUE(fs::exists(dir_ / "state" / "params.json")) << "the change persists";
}

TEST_F(ViewServerTest, ScanCommandsReachIoctRtAndBadOnesDoNot) {
  start();
  auto r = http_request(port_, "POST", "/api/scan", R"({"cmd":"start"})", kToken);
  EXPECT_EQ(r.status, 200u) << r.body;
  r = http_request(port_, "POST", "/api/scan", R"({"cmd":"stop","cmd":"start"})", kToken);
  EXPECT_EQ(r.status, 400u);
  EXPECT_NE(r.json()["error"].get<std::string>().find("appears twice"), std::string::npos);
  r = http_request(port_, "POST", "/api/scan", R"({"cmd":"start","laser":1})", kToken);
  EXPECT_EQ(r.status, 400u);
  EXPECT_EQ(r.json()["key"], "laser");
  r = http_request(port_, "POST", "/api/scan", R"({"cmd":"start"})");
  EXPECT_EQ(r.status, 401u);
  EXPECT_EQ(count_cmd(rt_->requests(), "start"), 1u) << "only the valid operator's start";
}

TEST_F(ViewServerTest, MalformedOversizedAndFloodingMessages) {
  start();
  WsViewer good(port_);
  WsViewer malformed(port_);
  malformed.send_raw("{not json");
  auto reply = malformed.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_NE((*reply)["error"].get<std::string>().find("not valid JSON"), std::string::npos);
  malformed.send_raw(R"({"type":"launch"})");
  reply = malformed.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ((*reply)["key"], "type");

  WsViewer oversized(port_);
  oversized.send_raw(std::string(70'000, ' '));
  EXPECT_FALSE(oversized.next_text("reply", 2s));
  EXPECT_TRUE(oversized.closed());

  WsViewer flood(port_);
  for (int i = 0; i < 1000 && !flood.closed(); ++i) {
    try {
      flood.send_raw(R"({"type":"follow"})");
    } catch (const std::exception&) {
      break;  // the server closed it
    }
  }
  bool closed = false;
  for (int i = 0; i < 2000 && !closed; ++i) closed = !flood.next(2s).has_value();
  EXPECT_TRUE(closed) << "a flooding client is closed";

  publish(1);
  auto frame = good.next_frame(2s);
  ASSERT_TRUE(frame) << "the well-behaved viewer is unaffected";
  EXPECT_EQ(frame->description["group"], 1);
  const std::string metrics = http_request(port_, "GET", "/metrics").body;
  EXPECT_NE(metrics.find("ioct_view_messages_refused_total"), std::string::npos);
}

// A field of the wrong type in a viewer's message is refused like any bad message: no viewer,
// token or not, can end the server for the others.
TEST_F(ViewServerTest, AMessageWithAFieldOfTheWrongTypeIsRefusedAndTheServerGoesOn) {
  start();
  WsViewer good(port_);
  ASSERT_TRUE(good.next_text("state", 2s)) << "joined";
  WsViewer odd(port_);
  const std::pair<nlohmann::json, const char*> messages[] = {
      {{{"type", "drawn"}, {"id", 1}, {"frame", "x"}}, "frame"},
      {{{"type", "drawn"}, {"id", 2}, {"frame", -3}}, "frame"},
      {{{"type", "drawn"}, {"id", 3}}, "frame"},
      {{{"type", "hello"}, {"id", 4}, {"token", 5}}, "token"},
      {{{"type", "own_view"}, {"id", 5}, {"changes", "x"}}, nullptr},
      {{{"type", "own_view"}, {"id", 6}, {"changes", {{"view", {{"zoom", 2}}}, {"mode", 1}}}},
       "mode"},
  };
  for (const auto& [message, key] : messages) {
    odd.send(message);
    const auto reply = odd.next_text("reply", 2s);
    ASSERT_TRUE(reply) << message.dump() << ": no reply (closed: " << odd.closed() << ")";
    EXPECT_EQ((*reply)["id"], message["id"]);
    EXPECT_EQ((*reply)["ok"], false) << message.dump();
    if (key != nullptr) {
      EXPECT_EQ(reply->value("key", ""), key) << reply->dump();
    }
  }
  publish(3);
  auto frame = good.next_frame(2s);
  ASSERT_TRUE(frame) << "the server goes on";
  EXPECT_EQ(frame->description["group"], 3);
  EXPECT_EQ(http_request(port_, "GET", "/api/state").status, 200u);
}

// ioct-gpu and ioct-rt of another version (or another service on their sockets) answering with
// fields of the wrong type: their errors name the field, and the view goes on without them.
TEST_F(ViewServerTest, RepliesOfTheWrongTypeFromTheBackendsAreErrorsThatNameTheField) {
  odd_replies_ = true;
  start();
  nlohmann::json state = state_when(
      [](const nlohmann::json& s) { return s["gpu_error"] != "" && s["rt_error"] != ""; });
  EXPECT_NE(state["gpu_error"].get<std::string>().find("\"generation\""), std::string::npos)
      << state["gpu_error"];
  EXPECT_TRUE(state["params"].is_null());
  EXPECT_NE(state["rt_error"].get<std::string>().find("\"ok\""), std::string::npos)
      << state["rt_error"];
  EXPECT_EQ(http_request(port_, "GET", "/api/params").status, 503u);
  EXPECT_NE(http_request(port_, "GET", "/metrics").body.find("ioct_rt_up 0"), std::string::npos);

  odd_replies_ = false;
  state = state_when(
      [](const nlohmann::json& s) { return s["params"].is_object() && s["rt"].is_object(); });
  EXPECT_EQ(state["gpu_error"], "");
  EXPECT_EQ(state["params"]["mode"], "enhanced");
}

// The operators' files in the state folder: one that cannot be used says which and why, where it
// is asked for (a preset) or where it was to be used (the last parameters, for a new ioct-gpu).
TEST_F(ViewServerTest, AStateFileThatCannotBeUsedIsNamedWithWhy) {
  start();
  state_when([](const nlohmann::json& s) { return s["params"].is_object(); });
  std::ofstream(dir_ / "state" / "presets" / "broken.json") << "{not json";
  for (const auto& [method, target] :
       {std::pair{"GET", "/api/presets/broken"}, std::pair{"POST", "/api/presets/broken/recall"}}) {
    const auto reply = http_request(port_, method, target, "", kToken);
    EXPECT_EQ(reply.status, 500u) << method << " " << target << ": " << reply.body;
    EXPECT_NE(reply.body.find("broken.json: not a JSON object"), std::string::npos) << reply.body;
  }
  EXPECT_EQ(http_request(port_, "GET", "/api/presets/absent").status, 404u);

  // A new view finds the last parameters unreadable, then ones ioct-gpu refuses.
  const auto problem_after_restart = [&](const std::string& params_json) {
    stop_server();
    std::ofstream(dir_ / "state" / "params.json") << params_json;
    start_server();
    return state_when([](const nlohmann::json& s) {
             return s["params"].is_object() && s["params_problem"] != "";
           })["params_problem"]
        .get<std::string>();
  };
  const std::string unreadable = problem_after_restart("[1, 2");
  EXPECT_NE(unreadable.find("params.json: not a JSON object"), std::string::npos) << unreadable;
  const std::string refused = problem_after_restart(R"({"enhanced": {"threshold": 2}})");
  EXPECT_NE(refused.find("ioct-gpu refused"), std::string::npos) << refused;
  EXPECT_NE(refused.find("render.enhanced.threshold"), std::string::npos) << refused;
  EXPECT_EQ(problem_after_restart(R"({"enhanced": {"threshold": 0.5}})"), "")
      << "restored: no problem";
}

TEST_F(ViewServerTest, ConnectionsBeyondTheLimitAreRefused) {
  start(4);
  std::vector<std::unique_ptr<WsViewer>> viewers;
  for (int i = 0; i < 4; ++i) viewers.push_back(std::make_unique<WsViewer>(port_));
  std::this_thread::sleep_for(100ms);
  EXPECT_ANY_THROW(WsViewer extra(port_));
  viewers.pop_back();
  std::this_thread::sleep_for(200ms);
  const std::string metrics = http_request(port_, "GET", "/metrics").body;
  EXPECT_NE(metrics.find("ioct_view_connections_refused_total 1"), std::string::npos) << metrics;
}

// One address cannot take every place: beyond its own limit it is refused while another
// address still gets in (127.0.0.2 is loopback too, another peer to the server).
TEST_F(ViewServerTest, OneAddressCannotTakeThePlacesOfTheOthers) {
  max_connections_per_address_ = 3;
  start();
  std::vector<std::unique_ptr<WsViewer>> hog;
  for (int i = 0; i < 3; ++i) {
    hog.push_back(std::make_unique<WsViewer>(port_));
    ASSERT_TRUE(hog.back()->next_text("state", 2s)) << "viewer " << i << " joined";
  }
  EXPECT_ANY_THROW(WsViewer extra(port_)) << "the fourth from 127.0.0.1";
  EXPECT_ANY_THROW(http_request(port_, "GET", "/api/state")) << "HTTP counts the same";
  WsViewer other(port_, "127.0.0.2");
  EXPECT_TRUE(other.next_text("state", 2s)) << "another address still gets in";
  // Asked from 127.0.0.2 while 127.0.0.1's places are all taken: exactly the two refused so far.
  EXPECT_EQ(metric(port_, "ioct_view_connections_refused_total", "127.0.0.2").value_or(-1.0), 2.0)
      << "the fourth WebSocket and the HTTP request, nothing else";
  hog.pop_back();
  // The server frees the place when it sees the close (a loaded machine: not at once).
  std::unique_ptr<WsViewer> again;
  for (auto end = std::chrono::steady_clock::now() + 10s;
       !again && std::chrono::steady_clock::now() < end; std::this_thread::sleep_for(50ms)) {
    try {
      again = std::make_unique<WsViewer>(port_);
    } catch (const std::exception&) {
    }
  }
  EXPECT_TRUE(again) << "a place freed is a place again";
}

// On loopback (the default listener) every peer is this machine: by default no limit per address
// beyond the whole one, so a 17th connection from 127.0.0.1 still gets in.
TEST_F(ViewServerTest, OnLoopbackThePerAddressLimitIsTheWholeOneByDefault) {
  max_connections_per_address_ = 0;
  start();
  std::vector<std::unique_ptr<WsViewer>> viewers;
  for (int i = 0; i < 20; ++i) {
    ASSERT_NO_THROW(viewers.push_back(std::make_unique<WsViewer>(port_))) << "viewer " << i;
  }
  EXPECT_EQ(http_request(port_, "GET", "/api/state").status, 200u);
}

TEST_F(ViewServerTest, AViewerMayOrbitItsOwnCameraOnly) {
  start();
  WsViewer viewer(port_);
  viewer.send({{"type", "own_view"}, {"id", 1}, {"changes", {{"view", {{"azimuth_deg", 10}}}}}});
  auto reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  ASSERT_EQ((*reply)["ok"], true) << reply->dump();
  const std::uint64_t view = (*reply)["view"];
  EXPECT_GT(view, 0u);
  EXPECT_EQ(count_cmd(gpu_->requests(), "open_view"), 1u);

  viewer.send({{"type", "own_view"}, {"id", 2}, {"changes", {{"enhanced", {{"kg1", 1}}}}}});
  reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ((*reply)["ok"], false) << "render parameters are for operators";

  WsViewer other(port_);
  ASSERT_TRUE(other.next_text("state", 2s)) << "joined";
  publish(5, 0);
  publish(6, view);
  auto frame = viewer.next_frame(2s);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->description["view"], view);
  EXPECT_EQ(frame->description["group"], 6);
  frame = other.next_frame(2s);
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->description["view"], 0) << "the others follow the shared view";
}

// Changes that come faster than ioct-gpu's replies (a drag sends one every 30 ms) go to the one
// view the first opened, and a follow closes that view: none is left rendering for nobody.
TEST_F(ViewServerTest, AViewersOwnViewIsOneViewHoweverFastItsChangesCome) {
  start();
  WsViewer viewer(port_);
  ASSERT_TRUE(viewer.next_text("state", 2s)) << "joined";
  for (int i = 0; i < 5; ++i) {
    viewer.send(
        {{"type", "own_view"}, {"id", i}, {"changes", {{"view", {{"azimuth_deg", 10 * i}}}}}});
  }
  viewer.send({{"type", "follow"}, {"id", 5}});
  std::set<std::uint64_t> views;
  for (int i = 0; i < 6; ++i) {
    const auto reply = viewer.next_text("reply", 2s);
    ASSERT_TRUE(reply) << "reply " << i;
    EXPECT_EQ((*reply)["ok"], true) << reply->dump();
    if ((*reply)["id"] != 5) views.insert((*reply)["view"].get<std::uint64_t>());
  }
  EXPECT_EQ(views.size(), 1u) << "every change went to one view";
  for (int i = 0; i < 100 && count_cmd(gpu_->requests(), "close_view") == 0; ++i) {
    std::this_thread::sleep_for(20ms);
  }
  const std::vector<nlohmann::json> requests = gpu_->requests();
  EXPECT_EQ(count_cmd(requests, "open_view"), 1u);
  EXPECT_EQ(count_cmd(requests, "set"), 4u);
  EXPECT_EQ(count_cmd(requests, "close_view"), 1u) << "the view the follow left is closed";
}

// ioct-gpu closes a connection's views with it: after it restarts, a viewer that orbited its own
// camera is told and follows the shared view again, instead of waiting for frames that never come
// under a picture that looks live.
TEST_F(ViewServerTest, AnOwnViewLostWithIoctGpusConnectionSendsTheViewerBackToTheSharedView) {
  start();
  WsViewer viewer(port_);
  ASSERT_TRUE(viewer.next_text("state", 2s)) << "joined";
  viewer.send({{"type", "own_view"}, {"id", 1}, {"changes", {{"view", {{"zoom", 2}}}}}});
  const auto reply = viewer.next_text("reply", 2s);
  ASSERT_TRUE(reply);
  ASSERT_EQ((*reply)["ok"], true) << reply->dump();

  gpu_.reset();  // ioct-gpu restarts
  gpu_ = std::make_unique<LineService>((dir_ / "gpu.sock").string(),
                                       [this](const nlohmann::json& r) { return gpu_reply(r); });
  const auto closed = viewer.next_text("own_view_closed", 3s);
  ASSERT_TRUE(closed) << "the viewer is told its view is gone";
  EXPECT_NE((*closed)["reason"].get<std::string>().find("ioct-gpu"), std::string::npos);
  for (int i = 0; i < 100 && count_cmd(gpu_->requests(), "close_view") == 0; ++i) {
    std::this_thread::sleep_for(20ms);
  }
  const std::vector<nlohmann::json> requests = gpu_->requests();
  ASSERT_EQ(count_cmd(requests, "close_view"), 1u) << "in case it was opened anew: not left";
  publish(7, 0);
  std::optional<ReceivedFrame> frame = viewer.next_frame(2s);
  ASSERT_TRUE(frame) << "the shared view's frames reach it again";
  EXPECT_EQ(frame->description["view"], 0);
  EXPECT_EQ(frame->description["group"], 7);
}

TEST_F(ViewServerTest, PresetsAreSavedRecalledAndNamedSafely) {
  start();
  state_when([](const nlohmann::json& s) { return s["params"].is_object(); });
  EXPECT_EQ(http_request(port_, "PUT", "/api/presets/night").status, 401u);
  EXPECT_EQ(http_request(port_, "PUT", "/api/presets/night", "", kToken).status, 200u);
  EXPECT_EQ(http_request(port_, "GET", "/api/presets").json()["presets"],
            nlohmann::json::array({"night"}));
  EXPECT_EQ(http_request(port_, "PUT", "/api/presets/..%2Fescape", "", kToken).status, 400u);
  EXPECT_EQ(http_request(port_, "POST", "/api/presets/night/recall", "", kToken).status, 200u);
  EXPECT_EQ(http_request(port_, "POST", "/api/presets/none/recall", "", kToken).status, 404u);
  EXPECT_EQ(http_request(port_, "DELETE", "/api/presets/night", "", kToken).status, 200u);
  EXPECT_TRUE(http_request(port_, "GET", "/api/presets").json()["presets"].empty());
}

TEST_F(ViewServerTest, PagesAndMetricsAreServed) {
  start();
  auto page = http_request(port_, "GET", "/");
  EXPECT_EQ(page.status, 200u);
  EXPECT_EQ(page.body, "<p>surgeon");
  EXPECT_EQ(http_request(port_, "GET", "/../token").status, 404u);
  EXPECT_EQ(http_request(port_, "POST", "/").status, 405u);
  report_live(2);
  std::string metrics;
  for (int i = 0; i < 100; ++i) {
    metrics = http_request(port_, "GET", "/metrics").body;
    if (metrics.find("ioct_rt_groups_published_total 5") != std::string::npos &&
        metrics.find("ioct_gpu_groups_consumed_total 3") != std::string::npos) {
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_NE(metrics.find("ioct_rt_groups_published_total 5"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("ioct_gpu_groups_consumed_total 3"), std::string::npos);
  EXPECT_NE(metrics.find("ioct_view_published_to_sent_seconds_count"), std::string::npos);
}

// ioct-view killed and restarted while ioct-gpu runs: the writer never notices (it never waits for
// a reader), and the new ioct-view serves the frames that come after.
TEST_F(ViewServerTest, ARestartedViewServesFramesAgainAndTheWriterNeverWaits) {
  start();
  {
    WsViewer viewer(port_);
    ASSERT_TRUE(viewer.next_text("state", 2s)) << "joined";  // frames before joining are not its
    publish(1);
    auto frame = viewer.next_frame(2s);
    ASSERT_TRUE(frame);
    EXPECT_EQ(frame->description["group"], 1);
  }
  stop_server();
  for (std::uint64_t g = 2; g < 40; ++g) publish(g);  // nobody reads: the writer goes on
  start_server();
  WsViewer viewer(port_);
  ASSERT_TRUE(viewer.next_text("state", 2s)) << "joined";
  publish(40);
  std::optional<testing::ReceivedFrame> frame;
  do {
    frame = viewer.next_frame(2s);
  } while (frame && frame->description["group"] != 40);
  ASSERT_TRUE(frame) << "the restarted view serves the new frames";
  const auto state = state_when([](const nlohmann::json& s) { return s["signal"] == "live"; },
                                [&] { report_live(40); });
  EXPECT_EQ(state["signal"], "live");
}

TEST_F(ViewServerTest, EachFootswitchPressTakesASnapshotAndTellsThePages) {
  start();
  WsViewer viewer(port_);
  state_when([](const nlohmann::json& s) { return s["rt"].is_object(); });
  const auto snapshots = [&] { return count_cmd(gpu_->requests(), "snapshot"); };
  for (int press = 1; press <= 2; ++press) {
    footswitch_ = true;
    auto event = viewer.next_text("footswitch", 3s);
    ASSERT_TRUE(event) << "press " << press;
    EXPECT_EQ((*event)["action"], "snapshot");
    for (int i = 0; i < 100 && snapshots() < static_cast<std::size_t>(press); ++i) {
      std::this_thread::sleep_for(20ms);
    }
    EXPECT_EQ(snapshots(), static_cast<std::size_t>(press));
    footswitch_ = false;
    std::this_thread::sleep_for(400ms);  // released for a few polls
  }
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(snapshots(), 2u) << "holding the pedal down is one press, not one per poll";
}

// A viewer whose frames back up (its writes wait on a full socket) still gets every footswitch
// event: the state messages that follow it must not replace it, or its page's B-scan panel is
// out of step with the others from then on.
TEST_F(ViewServerTest, AFootswitchEventReachesAViewerWhoseWritesAreBackedUp) {
  start();
  WsViewer slow(port_);
  ASSERT_TRUE(slow.next_text("state", 2s)) << "joined";
  state_when([](const nlohmann::json& s) { return s["rt"].is_object(); });
  const auto replaced = [&] {
    return metric(port_, "ioct_view_frames_replaced_total").value_or(0.0);
  };
  // Large frames that the viewer does not read, until one waits behind another.
  for (std::uint64_t g = 1; g < 200 && replaced() == 0.0; ++g) {
    publish(g, 0, (1 << 20) - 200);
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_GT(replaced(), 0.0) << "the viewer's writes never backed up";
  footswitch_ = true;
  state_when([&](const nlohmann::json&) { return count_cmd(gpu_->requests(), "snapshot") > 0; });
  footswitch_ = false;
  std::this_thread::sleep_for(600ms);  // state messages at 4 Hz meanwhile
  const auto event = slow.next_text("footswitch", 10s);
  ASSERT_TRUE(event) << "the footswitch event was replaced";
  EXPECT_EQ((*event)["action"], "snapshot");
}

// A snapshot waits for a full-size render, longer than any other reply of ioct-gpu (the CPU
// renderer takes seconds): it is given its own time bound, not the backends' 0.5 s.
TEST_F(ViewServerTest, ASnapshotMayTakeLongerThanOtherReplies) {
  snapshot_delay_ms_ = 1200;
  start();
  const auto reply = http_request(port_, "POST", "/api/snapshot", "{}", kToken);
  EXPECT_EQ(reply.status, 200u) << reply.body;
  EXPECT_NE(reply.body.find("s.png"), std::string::npos) << reply.body;
}

// ioct-gpu's slow replies (a snapshot waits for a full-size render) hold up nothing of ioct-rt's:
// a scan stop goes through at once and the scan's status goes on being polled meanwhile.
TEST_F(ViewServerTest, ASlowSnapshotHoldsUpNeitherAScanStopNorTheScansStatus) {
  snapshot_delay_ms_ = 2000;
  start();
  state_when([](const nlohmann::json& s) { return s["rt"].is_object(); });
  std::thread snapshot(
      [&] { EXPECT_EQ(http_request(port_, "POST", "/api/snapshot", "{}", kToken).status, 200u); });
  for (int i = 0; i < 100 && count_cmd(gpu_->requests(), "snapshot") == 0; ++i) {
    std::this_thread::sleep_for(10ms);
  }
  const std::size_t polls_before = count_cmd(rt_->requests(), "status");
  const auto t0 = std::chrono::steady_clock::now();
  const auto stop = http_request(port_, "POST", "/api/scan", R"({"cmd":"stop"})", kToken);
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(stop.status, 200u) << stop.body;
  EXPECT_LT(took, 1s) << "the stop waited for the snapshot";
  std::this_thread::sleep_for(500ms);
  EXPECT_GE(count_cmd(rt_->requests(), "status"), polls_before + 2)
      << "ioct-rt's status is polled while the snapshot waits";
  EXPECT_EQ(count_cmd(gpu_->requests(), "snapshot"), 1u);
  snapshot.join();
}

// ioct-rt counts the presses where it reads the line: taps between two status polls (the line
// never seen down by the view) each still act, and a restarted ioct-rt's count starts afresh.
TEST_F(ViewServerTest, FootswitchTapsBetweenStatusPollsAreNotLost) {
  footswitch_presses_ = 4;
  start();
  WsViewer viewer(port_);
  state_when([](const nlohmann::json& s) { return s["rt"].is_object(); });
  const auto snapshots = [&] { return count_cmd(gpu_->requests(), "snapshot"); };
  std::this_thread::sleep_for(300ms);  // a few polls at the first count
  EXPECT_EQ(snapshots(), 0u) << "the count ioct-rt had before is no press";
  footswitch_presses_ = 6;  // two taps, the line never down at a poll
  for (int press = 1; press <= 2; ++press) {
    auto event = viewer.next_text("footswitch", 3s);
    ASSERT_TRUE(event) << "tap " << press;
    EXPECT_EQ((*event)["action"], "snapshot");
  }
  for (int i = 0; i < 100 && snapshots() < 2; ++i) std::this_thread::sleep_for(20ms);
  EXPECT_EQ(snapshots(), 2u);
  footswitch_presses_ = 0;  // ioct-rt restarted
  std::this_thread::sleep_for(300ms);
  footswitch_presses_ = 1;
  auto event = viewer.next_text("footswitch", 3s);
  ASSERT_TRUE(event) << "the restarted ioct-rt's first press";
  for (int i = 0; i < 100 && snapshots() < 3; ++i) std::this_thread::sleep_for(20ms);
  EXPECT_EQ(snapshots(), 3u);
}

}  // namespace
}  // namespace ioct::view
