// The recorder's figures on ioct-view's /metrics: the ioct_record_* text from a status as the real
// recorder writes it (ringrec::recorder_status_json), and end to end through ioct-view, which
// polls a stand-in for ioct-record's socket: the values move with the recording, and a recorder
// that is not configured or not there gives no recording metrics and no error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>

#include "ioct/ringrec/recorder_control.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "line_service.hpp"
#include "operator_token.hpp"
#include "recording_metrics.hpp"
#include "view_client.hpp"
#include "view_server.hpp"

namespace ioct::view {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::http_request;
using testing::LineService;

ringrec::RecorderStatus recording(std::uint64_t groups) {
  ringrec::RecorderStatus s;
  s.attached = true;
  s.recording = true;
  s.standby = true;
  s.file = "/data/run-7.h5";
  s.seconds = 2.5;
  auto set = [&](ringrec::Counter c, std::uint64_t v) {
    s.counters[static_cast<std::size_t>(c)] = v;
  };
  set(ringrec::Counter::groups_written, groups);
  set(ringrec::Counter::bytes_written, groups * 1000);
  set(ringrec::Counter::dropped_lapped, 1);
  set(ringrec::Counter::dropped_behind, 2);
  set(ringrec::Counter::dropped_queue_full, 3);
  set(ringrec::Counter::dropped_disk_full, 4);
  s.queued = 5;
  s.queue_capacity = 8;
  return s;
}

TEST(RecordingMetrics, TheRecordersStatusBecomesIoctRecordMetrics) {
  std::string out;
  write_recording_metrics(ringrec::recorder_status_json(recording(42)), out);
  for (const char* line :
       {"\nioct_record_recording 1\n", "\nioct_record_attached 1\n",
        "\nioct_record_groups_written_total 42\n", "\nioct_record_bytes_written_total 42000\n",
        "\nioct_record_dropped_total{cause=\"lapped\"} 1\n",
        "\nioct_record_dropped_total{cause=\"behind\"} 2\n",
        "\nioct_record_dropped_total{cause=\"queue_full\"} 3\n",
        "\nioct_record_dropped_total{cause=\"disk_full\"} 4\n", "\nioct_record_queue_groups 5\n",
        "\nioct_record_queue_capacity_groups 8\n", "\nioct_record_seconds 2.5\n",
        "# TYPE ioct_record_dropped_total counter\n"}) {
    EXPECT_NE(out.find(line), std::string::npos) << "no " << line << " in\n" << out;
  }
  std::string idle;
  write_recording_metrics(ringrec::recorder_status_json(ringrec::RecorderStatus{}), idle);
  EXPECT_NE(idle.find("\nioct_record_recording 0\n"), std::string::npos) << idle;
  std::string none;
  write_recording_metrics(nullptr, none);
  EXPECT_TRUE(none.empty());
}

class RecordingMetricsViewTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ioct-view-record-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "www");
    std::ofstream(dir_ / "www" / "index.html") << "<p>view";
    std::ofstream(dir_ / "token") << "test-operator-token-0123456789\n";
    fs::permissions(dir_ / "token", fs::perms::owner_read | fs::perms::owner_write);
  }
  void TearDown() override {
    if (server_) {
      server_->stop();
      thread_.join();
      server_.reset();
    }
    recorder_.reset();
    fs::remove_all(dir_);
  }
  void start_view(const fs::path& record_socket, const fs::path& control_socket = {}) {
    ViewConfig config;
    config.control_socket = control_socket;
    config.port = 0;
    config.frames = frames_.str();
    config.record_socket = record_socket;
    config.www_dir = dir_ / "www";
    config.state_dir = dir_ / "state";
    config.rt_status_interval_s = 0.05;
    server_ = std::make_unique<ViewServer>(config, OperatorToken::read(dir_ / "token"));
    thread_ = std::thread([this] { server_->run(); });
  }
  // /metrics once it holds `text`, or its last body after 5 s.
  std::string metrics_when(const std::string& text) {
    std::string body;
    for (int i = 0; i < 250; ++i) {
      body = http_request(server_->port(), "GET", "/metrics").body;
      if (body.find(text) != std::string::npos) break;
      std::this_thread::sleep_for(20ms);
    }
    return body;
  }

  fs::path dir_;
  test_support::ScopedShmName frames_{"view-record-frames"};
  std::unique_ptr<LineService> recorder_;
  std::unique_ptr<ViewServer> server_;
  std::thread thread_;
};

TEST_F(RecordingMetricsViewTest, TheValuesMoveWithTheRecording) {
  std::atomic<std::uint64_t> groups{0};
  std::atomic<bool> on{false};
  recorder_ = std::make_unique<LineService>(
      (dir_ / "record.sock").string(), [&](const nlohmann::json& request) {
        if (request.value("cmd", "") != "record-status") {
          return nlohmann::json{{"ok", false}, {"error", "unexpected"}};
        }
        ringrec::RecorderStatus s = on ? recording(groups += 7) : ringrec::RecorderStatus{};
        s.attached = true;
        return nlohmann::json{
            {"ok", true}, {"cmd", "record-status"}, {"status", ringrec::recorder_status_json(s)}};
      });
  start_view(dir_ / "record.sock");
  std::string body = metrics_when("\nioct_record_recording 0\n");
  EXPECT_NE(body.find("\nioct_record_recording 0\n"), std::string::npos) << body;
  EXPECT_NE(body.find("\nioct_record_groups_written_total 0\n"), std::string::npos) << body;
  on = true;
  body = metrics_when("\nioct_record_recording 1\n");
  ASSERT_NE(body.find("\nioct_record_recording 1\n"), std::string::npos) << body;
  const auto written = [](const std::string& text) {
    const std::string name = "\nioct_record_groups_written_total ";
    const std::size_t at = text.find(name);
    return at == std::string::npos ? 0.0 : std::stod(text.substr(at + name.size()));
  };
  const double first = written(body);
  EXPECT_GT(first, 0.0);
  std::string later;
  for (int i = 0; i < 250 && written(later) <= first; ++i) {
    later = http_request(server_->port(), "GET", "/metrics").body;
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_GT(written(later), first) << "the groups written never moved:\n" << later;
}

TEST_F(RecordingMetricsViewTest, NoRecorderMeansNoRecordingMetricsAndNoError) {
  // A stand-in for ioct-rt: its figures on /metrics show that a poll, which asks the recorder
  // in the same round, has happened.
  recorder_ = std::make_unique<LineService>((dir_ / "rt.sock").string(), [](const nlohmann::json&) {
    return nlohmann::json{{"ok", true}, {"status", {{"acquisition", {{"groups_published", 9}}}}}};
  });
  start_view(dir_ / "absent.sock", dir_ / "rt.sock");  // a recorder configured, nobody listening
  // ioct-rt's figures are served; ioct_record_* are not, and nothing fails.
  const std::string body = metrics_when("\nioct_rt_groups_published_total 9\n");
  ASSERT_NE(body.find("\nioct_rt_groups_published_total 9\n"), std::string::npos) << body;
  EXPECT_EQ(body.find("ioct_record_"), std::string::npos) << body;
  EXPECT_EQ(http_request(server_->port(), "GET", "/api/state").status, 200u);
}

}  // namespace
}  // namespace ioct::view
