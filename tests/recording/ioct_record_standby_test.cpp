// ioct-record --standby beside a simulated ioct-rt, driven through its control socket: follows
// the ring without writing (its reader status counting the groups it read), records from
// record-start to record-stop (or the recording's seconds), again into a second file, refuses bad
// names, an existing file, a second start and a stop with nothing recording, each naming the
// command and the value; both files open with their groups, in order and intact. ioct-rtctl reaches
// the same socket.
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ioct/common/line_client.hpp"
#include "ioct/ringrec/ring_recording_reader.hpp"
#include "ioct/shm/reader_status.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "recording_processes.hpp"

namespace ioct::ringrec {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using test_support::ChildProcess;

using test::small_rt;
using test::start;

int exit_code(const std::optional<int>& status) {
  if (!status.has_value()) return -1000;  // still running
  return WIFEXITED(*status) ? WEXITSTATUS(*status) : -WTERMSIG(*status);
}

struct TempDirectory {
  TempDirectory()
      : path(fs::temp_directory_path() / ("ioct-standby-" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDirectory() { fs::remove_all(path); }
  fs::path path;
};

// One command to the recorder's socket; the parsed reply (null when there was none).
class Recorder {
 public:
  explicit Recorder(const fs::path& socket) : client_(socket.string(), 20s) {}
  nlohmann::json send(const nlohmann::json& request) {
    const std::optional<std::string> line = client_.request(request.dump());
    if (!line) return nullptr;
    return nlohmann::json::parse(*line, nullptr, false);
  }
  nlohmann::json status() { return send({{"cmd", "record-status"}})["status"]; }
  // Waits (bounded) until the recording under way has written `groups` groups.
  bool wait_for_groups(std::uint64_t groups) {
    const auto end = std::chrono::steady_clock::now() + 60s;
    while (std::chrono::steady_clock::now() < end) {
      const nlohmann::json s = status();
      if (s.is_object() && s["recording"].get<bool>() &&
          s["groups_written"].get<std::uint64_t>() >= groups) {
        return true;
      }
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }
  const std::string& last_error() const { return client_.last_error(); }

 private:
  LineClient client_;
};

// The groups ioct-record has read, as its reader status tells ioct-rt; nullopt when it has none.
std::optional<std::uint64_t> recorder_consumed(const std::string& ring) {
  for (const shm::ReaderReport& reader : shm::scan_reader_status(ring)) {
    if (reader.label == "ioct-record" && reader.alive) return reader.counters.consumed;
  }
  return std::nullopt;
}

std::string error_of(const nlohmann::json& reply) {
  EXPECT_TRUE(reply.is_object()) << "no reply";
  if (!reply.is_object()) return "";
  EXPECT_FALSE(reply.value("ok", true)) << reply.dump();
  return reply.value("error", "");
}

// The file opens, is finished, and holds `at_least` groups in publication order, each intact
// (read_group checks the checksum). Returns its first and last ring group index.
std::pair<std::uint64_t, std::uint64_t> check_file(const fs::path& path, std::uint64_t at_least) {
  const RingRecordingReader reader(path);
  EXPECT_TRUE(reader.finished()) << path;
  EXPECT_GE(reader.group_count(), at_least) << path;
  EXPECT_EQ(reader.counters()[static_cast<std::size_t>(Counter::groups_written)],
            reader.group_count());
  std::vector<std::byte> payload(reader.group_bytes());
  shm::SlotHeader header{};
  std::uint64_t first = 0, previous = 0;
  for (std::uint64_t i = 0; i < reader.group_count(); ++i) {
    reader.read_group(i, payload, header);
    if (i == 0) first = header.group_index;
    if (i > 0) {
      EXPECT_GT(header.group_index, previous) << path << " group " << i;
    }
    previous = header.group_index;
  }
  return {first, previous};
}

TEST(IoctRecordStandby, StartStopAndStartAgainIntoASecondFileWhileIoctRtRuns) {
  const test_support::ScopedShmName ring("standby");
  const TempDirectory dir;
  const fs::path socket = dir.path / "record.sock";
  ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
  ChildProcess recorder =
      start("ioct-record",
            {"--ring", ring.str(), "--standby", "--out", dir.path.string(), "--control-socket",
             socket.string(), "--wait", "30", "--status-interval", "0.5"});
  Recorder control(socket);
  nlohmann::json status;
  for (int tries = 0; tries < 1500; ++tries) {  // the socket, then the ring attached
    status = control.status();
    if (status.is_object() && status["attached"].get<bool>()) break;
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_TRUE(status.is_object()) << "no reply on " << socket << ": " << control.last_error();
  ASSERT_TRUE(status["attached"].get<bool>()) << status.dump();
  EXPECT_FALSE(status["recording"].get<bool>());
  EXPECT_TRUE(status["standby"].get<bool>());

  // Standby: nothing written, and the refusals.
  EXPECT_EQ(error_of(control.send({{"cmd", "record-stop"}})), "record-stop: not recording");
  EXPECT_NE(error_of(control.send({{"cmd", "record-start"}, {"name", "../escape"}}))
                .find("record-start: name = '../escape': must be a file name without a path "
                      "separator"),
            std::string::npos);
  EXPECT_NE(error_of(control.send({{"cmd", "record-start"}, {"name", "bad\x01name"}}))
                .find("control bytes"),
            std::string::npos);
  // It follows the ring meanwhile: its reader status (what ioct-rt sees) counts groups read.
  const std::optional<std::uint64_t> consumed = recorder_consumed(ring.str());
  ASSERT_TRUE(consumed.has_value()) << "no live reader status labelled ioct-record";
  std::optional<std::uint64_t> later = consumed;
  for (int tries = 0; tries < 1500 && later.value_or(0) < *consumed + 5; ++tries) {
    std::this_thread::sleep_for(20ms);
    later = recorder_consumed(ring.str());
  }
  EXPECT_GE(later.value_or(0), *consumed + 5) << "the recorder in standby stopped reading";
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(dir.path)) {
    if (entry.path() != socket) files.push_back(entry.path().filename().string());
  }
  EXPECT_TRUE(files.empty()) << "standby wrote " << files.front();

  // The first recording.
  nlohmann::json reply = control.send({{"cmd", "record-start"}, {"name", "first"}});
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
  EXPECT_EQ(reply["status"]["file"], (dir.path / "first.h5").string());
  ASSERT_TRUE(control.wait_for_groups(10)) << control.status().dump();
  EXPECT_NE(error_of(control.send({{"cmd", "record-start"}, {"name", "other"}}))
                .find("already recording into " + (dir.path / "first.h5").string()),
            std::string::npos);
  reply = control.send({{"cmd", "record-stop"}});
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
  EXPECT_FALSE(reply["status"]["recording"].get<bool>());
  const nlohmann::json& last = reply["status"]["last"];
  EXPECT_EQ(last["file"], (dir.path / "first.h5").string());
  EXPECT_EQ(last["stop_reason"], "stopped by record-stop");
  const std::uint64_t first_groups = last["groups_written"].get<std::uint64_t>();
  EXPECT_GE(first_groups, 10u);

  // Its name is taken now; a second recording, stopped through ioct-rtctl.
  EXPECT_NE(error_of(control.send({{"cmd", "record-start"}, {"name", "first.h5"}}))
                .find("exists; not overwriting it"),
            std::string::npos);
  reply = control.send({{"cmd", "record-start"}, {"name", "second"}, {"seconds", 600}});
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump();
  ASSERT_TRUE(control.wait_for_groups(10)) << control.status().dump();
  ChildProcess rtctl = start("ioct-rtctl", {"--socket", socket.string(), "record-stop"});
  const std::optional<std::string> rtctl_reply = rtctl.read_line(30s);
  EXPECT_EQ(exit_code(rtctl.wait_for(30s)), 0) << rtctl_reply.value_or("(no output)");
  ASSERT_TRUE(rtctl_reply.has_value());
  const nlohmann::json stopped = nlohmann::json::parse(*rtctl_reply, nullptr, false);
  ASSERT_TRUE(stopped.is_object()) << *rtctl_reply;
  EXPECT_EQ(stopped["status"]["last"]["file"], (dir.path / "second.h5").string());

  recorder.send_signal(SIGTERM);
  EXPECT_EQ(exit_code(recorder.wait_for(30s)), 0);
  rt.send_signal(SIGTERM);
  EXPECT_EQ(exit_code(rt.wait_for(30s)), 0);

  const auto [first_begin, first_end] = check_file(dir.path / "first.h5", 10);
  const auto [second_begin, second_end] = check_file(dir.path / "second.h5", 10);
  EXPECT_EQ(RingRecordingReader(dir.path / "first.h5").group_count(), first_groups);
  EXPECT_GT(second_begin, first_end) << "the second recording holds groups of the first";
  std::printf(
      "[ recorded ] first.h5: ring groups %llu..%llu, second.h5: %llu..%llu\n",
      static_cast<unsigned long long>(first_begin), static_cast<unsigned long long>(first_end),
      static_cast<unsigned long long>(second_begin), static_cast<unsigned long long>(second_end));
}

TEST(IoctRecordStandby, ARecordingsSecondsEndItAndTheRecorderStaysInStandby) {
  const test_support::ScopedShmName ring("standby-timed");
  const TempDirectory dir;
  const fs::path socket = dir.path / "record.sock";
  ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
  ChildProcess recorder =
      start("ioct-record", {"--ring", ring.str(), "--standby", "--out", dir.path.string(),
                            "--control-socket", socket.string(), "--wait", "30"});
  Recorder control(socket);
  nlohmann::json reply;
  for (int tries = 0; tries < 1500; ++tries) {
    reply = control.send({{"cmd", "record-start"}, {"name", "timed"}, {"seconds", 0.5}});
    if (reply.is_object() && reply.value("ok", false)) break;
    std::this_thread::sleep_for(20ms);  // the socket, then the ring, not there yet
  }
  ASSERT_TRUE(reply.value("ok", false)) << reply.dump() << " " << control.last_error();
  nlohmann::json status;
  for (int tries = 0; tries < 3000; ++tries) {
    status = control.status();
    if (status.is_object() && !status["recording"].get<bool>()) break;
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_FALSE(status["recording"].get<bool>()) << status.dump();
  EXPECT_EQ(status["last"]["stop_reason"], "time limit");
  EXPECT_EQ(error_of(control.send({{"cmd", "record-stop"}})), "record-stop: not recording");
  recorder.send_signal(SIGINT);
  EXPECT_EQ(exit_code(recorder.wait_for(30s)), 0);
  check_file(dir.path / "timed.h5", 1);
}

// Started with its file (no standby), a record-stop on its control socket ends the recording and
// the process, whose summary is the recording's (before, it stayed attached with nothing to do).
TEST(IoctRecordStandby, ARecordStopEndsARecorderStartedWithItsFile) {
  const test_support::ScopedShmName ring("record-stop");
  const TempDirectory dir;
  const fs::path socket = dir.path / "record.sock";
  const fs::path file = dir.path / "run.h5";
  ChildProcess rt = start("ioct-rt", small_rt(ring.str()));
  ChildProcess recorder =
      start("ioct-record", {"--ring", ring.str(), "--out", file.string(), "--control-socket",
                            socket.string(), "--wait", "30", "--status-interval", "0"});
  Recorder control(socket);
  nlohmann::json status;
  for (int tries = 0; tries < 3000; ++tries) {  // the socket, then the first groups
    status = control.status();
    if (status.is_object() && status.value("groups_written", std::uint64_t{0}) >= 5) break;
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_TRUE(status.is_object() && status.value("groups_written", std::uint64_t{0}) >= 5)
      << status.dump() << " " << control.last_error();
  const nlohmann::json reply = control.send({{"cmd", "record-stop"}});
  EXPECT_TRUE(reply.value("ok", false)) << reply.dump();
  EXPECT_EQ(exit_code(recorder.wait_for(30s)), 0) << "the recorder ends with its recording";
  std::string output;
  while (std::optional<std::string> line = recorder.read_line(1s)) output += *line + "\n";
  EXPECT_NE(output.find("stopped by record-stop after"), std::string::npos) << output;
  EXPECT_EQ(output.find("groups (0 bytes"), std::string::npos) << "the recording's figures\n"
                                                               << output;
  check_file(file, 5);
}

}  // namespace
}  // namespace ioct::ringrec
