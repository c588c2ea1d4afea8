// ioct-rt as systemd runs it and as an operator checks it: it tells systemd READY, feeds the
// watchdog and says STOPPING over $NOTIFY_SOCKET; --check-config accepts the sample configs and
// refuses a bad file with exit status 2; --self-test measures wake-up latency and judges it.
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "ioct/shm/shm_object.hpp"
#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "ioct/test_support/small_rt_run.hpp"

namespace ioct {
namespace {

using namespace std::chrono_literals;
using test_support::ChildProcess;

int exit_code(const std::optional<int>& status) {
  if (!status) return -1000;
  return WIFEXITED(*status) ? WEXITSTATUS(*status) : -WTERMSIG(*status);
}

std::vector<std::string> small_run(const std::string& ring) {
  return test_support::small_rt_run(ring);
}

std::filesystem::path temp_dir(const char* tag) {
  const auto dir = std::filesystem::temp_directory_path() /
                   (std::string("ioct-rt-") + tag + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(IoctRtService, TellsSystemdReadyFeedsTheWatchdogAndSaysStopping) {
  const auto dir = temp_dir("notify");
  const std::string path = (dir / "notify.sock").string();
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);

  const test_support::ScopedShmName ring("rt-notify");
  ::setenv("NOTIFY_SOCKET", path.c_str(), 1);
  ::setenv("WATCHDOG_USEC", "100000", 1);  // ping at least every 50 ms
  ChildProcess rt =
      ChildProcess::spawn(test_support::sibling_executable("ioct-rt"), small_run(ring.str()));
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");

  std::vector<std::string> messages;
  const auto receive_until = [&](const std::string& wanted, std::chrono::milliseconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char buffer[1024];
      const ssize_t got = ::recv(fd, buffer, sizeof(buffer), 0);
      if (got <= 0) continue;
      messages.emplace_back(buffer, static_cast<std::size_t>(got));
      if (messages.back().find(wanted) != std::string::npos) return true;
    }
    return false;
  };
  ASSERT_TRUE(receive_until("READY=1", 20s));
  const auto ready_at = std::chrono::steady_clock::now();
  int pings = 0;
  while (pings < 5 && receive_until("WATCHDOG=1", 5s)) ++pings;
  EXPECT_EQ(pings, 5);
  EXPECT_LT(std::chrono::steady_clock::now() - ready_at, 2s) << "pinged every 50 ms or so";
  rt.send_signal(SIGTERM);
  EXPECT_TRUE(receive_until("STOPPING=1", 10s));
  EXPECT_EQ(exit_code(rt.wait_for(20s)), 0);
  ::close(fd);
  std::filesystem::remove_all(dir);
}

TEST(IoctRtService, CheckConfigAcceptsTheSampleConfigsAndRefusesABadFile) {
  for (const char* name : {"simulator.toml", "paper-100khz.toml", "bench.toml"}) {
    SCOPED_TRACE(name);
    ChildProcess check = ChildProcess::spawn(
        test_support::sibling_executable("ioct-rt"),
        {"--config", std::string(IOCT_RT_CONFIG_DIR) + "/" + name, "--check-config"});
    const std::optional<std::string> line = check.read_line(20s);
    ASSERT_TRUE(line.has_value());
    EXPECT_EQ(line->rfind("configuration ok: ", 0), 0u) << *line;
    EXPECT_EQ(exit_code(check.wait_for(20s)), 0);
  }
  const auto dir = temp_dir("badconfig");
  const test_support::ScopedShmName ring("rt-badconfig");
  const std::vector<std::string> bad = {
      "[scan]\nzoom = 2\n",                    // unknown key
      "[digitizer]\nascans_per_bscan = -1\n",  // out of range
      "[galvo]\nmax_acceleration = 1e7\n",     // infeasible scan
      "[ring\nname = \"x\"\n",                 // not TOML
  };
  for (const std::string& text : bad) {
    SCOPED_TRACE(text);
    const auto file = dir / "bad.toml";
    std::ofstream(file) << text;
    ChildProcess rt = ChildProcess::spawn(
        test_support::sibling_executable("ioct-rt"),
        {"--config", file.string(), "--ring", ring.str(), "--rt-priority", "0"});
    EXPECT_EQ(exit_code(rt.wait_for(20s)), 2);
    EXPECT_FALSE(shm::ShmObject::exists(ring.str())) << "no ring for a refused configuration";
  }
  std::filesystem::remove_all(dir);
}

// Issue F7: --check-config prints the effective configuration, and refuses an empty file and a
// hardware file cut off before its [control] table (which would have started the scan at once
// with no control socket).
TEST(IoctRtService, CheckConfigPrintsTheEffectiveConfigAndRefusesEmptyOrCutHardwareFiles) {
  const std::string paper = std::string(IOCT_RT_CONFIG_DIR) + "/paper-100khz.toml";
  {
    ChildProcess check = ChildProcess::spawn(test_support::sibling_executable("ioct-rt"),
                                             {"--config", paper, "--check-config"});
    std::vector<std::string> lines;
    while (const std::optional<std::string> line = check.read_line(20s)) lines.push_back(*line);
    EXPECT_EQ(exit_code(check.wait_for(20s)), 0);
    const auto has = [&](const std::string& wanted) {
      return std::find(lines.begin(), lines.end(), wanted) != lines.end();
    };
    EXPECT_TRUE(has("[control]"));
    EXPECT_TRUE(has("start_scanning = false"));
    EXPECT_TRUE(has("socket = \"/run/ioct/rt.sock\""));
    EXPECT_TRUE(has("max_velocity = 25000.0"));
  }
  std::ifstream in(paper);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto control = text.find("[control]");
  ASSERT_NE(control, std::string::npos);
  const auto dir = temp_dir("cutconfig");
  const test_support::ScopedShmName ring("rt-cutconfig");
  for (const std::string& cut : {std::string(), std::string("# nothing but a comment\n"),
                                 text.substr(0, control), text.substr(0, control + 12)}) {
    SCOPED_TRACE(cut.size());
    const auto file = dir / "cut.toml";
    std::ofstream(file) << cut;
    for (const bool check_only : {true, false}) {
      std::vector<std::string> args = {"--config", file.string(),   "--ring",
                                       ring.str(), "--rt-priority", "0"};
      if (check_only) args.push_back("--check-config");
      ChildProcess rt = ChildProcess::spawn(test_support::sibling_executable("ioct-rt"), args);
      EXPECT_EQ(exit_code(rt.wait_for(20s)), 2);
      EXPECT_FALSE(shm::ShmObject::exists(ring.str()));
    }
  }
  std::filesystem::remove_all(dir);
}

// Issue F3: --check-config refuses a ring that cannot fit where it would live.
TEST(IoctRtService, CheckConfigRefusesARingLargerThanTheRoomForIt) {
  const test_support::ScopedShmName ring("rt-huge");
  const std::optional<std::uint64_t> room = shm::room_for_object(ring.str());
  ASSERT_TRUE(room.has_value());
  // 4096 slots of the default geometry: about 92 GB.
  const std::uint64_t needed = 4096ull * 1376 * 512 * 16 * 2;
  if (needed <= *room) GTEST_SKIP() << "/dev/shm has room for " << *room << " bytes";
  ChildProcess check =
      ChildProcess::spawn(test_support::sibling_executable("ioct-rt"),
                          {"--ring", ring.str(), "--slots", "4096", "--check-config"});
  EXPECT_EQ(exit_code(check.wait_for(20s)), 2);
  EXPECT_FALSE(shm::ShmObject::exists(ring.str()));
}

TEST(IoctRtService, TheHardwareConfigWithoutItsInstrumentFailsWithoutARing) {
  // The paper's system asks for the USB instrument and the GPIO chip, which this machine lacks:
  // a runtime error (1), or a configuration error (2) where the build has no USB backend.
  const test_support::ScopedShmName ring("rt-nohw");
  ChildProcess rt =
      ChildProcess::spawn(test_support::sibling_executable("ioct-rt"),
                          {"--config", std::string(IOCT_RT_CONFIG_DIR) + "/paper-100khz.toml",
                           "--ring", ring.str(), "--rt-priority", "0", "--control-socket", ""});
  const int code = exit_code(rt.wait_for(30s));
  EXPECT_TRUE(code == 1 || code == 2) << code;
  EXPECT_FALSE(shm::ShmObject::exists(ring.str()));
}

TEST(IoctRtService, SelfTestMeasuresWakeUpLatencyAndJudgesItAgainstTheThreshold) {
  ChildProcess pass =
      ChildProcess::spawn(test_support::sibling_executable("ioct-rt"),
                          {"--self-test", "--self-test-seconds", "0.3", "--self-test-interval-us",
                           "1000", "--self-test-threshold-us", "10000000", "--rt-priority", "0"});
  std::string report;
  while (const std::optional<std::string> line = pass.read_line(20s)) report += *line + "\n";
  EXPECT_EQ(exit_code(pass.wait_for(20s)), 0) << report;
  EXPECT_NE(report.find("300 wake-ups every 1000 us"), std::string::npos) << report;
  EXPECT_NE(report.find("self-test: PASS"), std::string::npos) << report;
  EXPECT_NE(report.find("kernel "), std::string::npos) << report;

  // Nothing wakes within a microsecond of its deadline: a 1 us threshold fails.
  ChildProcess fail = ChildProcess::spawn(test_support::sibling_executable("ioct-rt"),
                                          {"--self-test", "--self-test-seconds", "0.1",
                                           "--self-test-threshold-us", "1", "--rt-priority", "0"});
  report.clear();
  while (const std::optional<std::string> line = fail.read_line(20s)) report += *line + "\n";
  EXPECT_EQ(exit_code(fail.wait_for(20s)), 1) << report;
  EXPECT_NE(report.find("self-test: FAIL"), std::string::npos) << report;
}

}  // namespace
}  // namespace ioct
