// ioct-rt's control socket as a client sees it: the socket is 0660, answers status, start, stop
// and scan changes, and meets garbage, over-long lines, unknown verbs, wrong types, out-of-range
// values and too many clients with clear error replies while the acquisition runs on untouched.
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ioct/test_support/child_process.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "ioct/test_support/small_rt_run.hpp"

namespace ioct {
namespace {

using namespace std::chrono_literals;
using test_support::ChildProcess;

class Client {
 public:
  explicit Client(const std::string& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  }
  ~Client() { ::close(fd_); }
  bool connected() const { return connected_; }
  void send(const std::string& bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return;
      sent += static_cast<std::size_t>(n);
    }
  }
  std::optional<std::string> line(std::chrono::milliseconds timeout = 10s) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        std::string l = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return l;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (left.count() <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return std::nullopt;
      char chunk[65536];
      const ssize_t got = ::recv(fd_, chunk, sizeof(chunk), 0);
      if (got <= 0) return std::nullopt;
      buffer_.append(chunk, static_cast<std::size_t>(got));
    }
  }
  // Closes this side and waits (up to `timeout`) until the server has closed the other: from
  // then on this client holds none of the server's places.
  bool hang_up(std::chrono::milliseconds timeout = 5s) {
    ::shutdown(fd_, SHUT_WR);
    const auto end = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      pollfd p{fd_, POLLIN, 0};
      if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
      char chunk[4096];
      if (::recv(fd_, chunk, sizeof(chunk), 0) <= 0) return true;
    }
  }
  nlohmann::json ask(const std::string& request) {
    send(request + "\n");
    const std::optional<std::string> reply = line();
    if (!reply) return {{"no_reply", true}};
    return nlohmann::json::parse(*reply, nullptr, false);
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  std::string buffer_;
};

class ControlSocket : public testing::Test {
 protected:
  // Added to ioct-rt's command line.
  virtual std::vector<std::string> extra_arguments() { return {}; }

  void SetUp() override {
    dir_ =
        std::filesystem::temp_directory_path() / ("ioct-rt-control-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    socket_ = (dir_ / "rt.sock").string();
    std::vector<std::string> arguments = test_support::small_rt_run(
        ring_.str(), {"--status-interval", "0.5", "--control-socket", socket_});
    for (const std::string& a : extra_arguments()) arguments.push_back(a);
    rt_.emplace(ChildProcess::spawn(test_support::sibling_executable("ioct-rt"), arguments));
    // The socket's file appears at bind(), a moment before listen(): a connection made in between
    // is refused. Wait until one is served, then hang it up and wait until the server has let it
    // go, so that the test starts with every client place free.
    const auto end = std::chrono::steady_clock::now() + 20s;
    while (std::chrono::steady_clock::now() < end) {
      Client probe(socket_);
      if (probe.connected() && probe.ask(R"({"cmd":"status"})").value("ok", false)) {
        ASSERT_TRUE(probe.hang_up()) << "ioct-rt did not close a client that hung up";
        break;
      }
      std::this_thread::sleep_for(10ms);
    }
  }
  void TearDown() override {
    if (rt_) {
      rt_->send_signal(SIGTERM);
      const std::optional<int> status = rt_->wait_for(20s);
      ASSERT_TRUE(status.has_value());
      EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0)
          << test_support::describe_wait_status(*status);
    }
    EXPECT_FALSE(std::filesystem::exists(socket_)) << "the socket is removed at exit";
    std::filesystem::remove_all(dir_);
  }
  nlohmann::json status(Client& c) { return c.ask(R"({"cmd":"status"})").at("status"); }

  test_support::ScopedShmName ring_{"rt-control"};
  std::filesystem::path dir_;
  std::string socket_;
  std::optional<ChildProcess> rt_;
};

TEST_F(ControlSocket, AnswersTheVerbsAndRefusesEveryKindOfBadInput) {
  struct stat st {};
  ASSERT_EQ(::stat(socket_.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0660u) << "access by filesystem permissions: owner and group";

  Client c(socket_);
  ASSERT_TRUE(c.connected());
  const auto end = std::chrono::steady_clock::now() + 20s;
  while (status(c)["safety"]["state"] != "scanning" && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(20ms);
  }
  const nlohmann::json before = status(c);
  ASSERT_EQ(before["safety"]["state"], "scanning");

  // Garbage of every kind: each gets an error reply on its own line, the connection stays.
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"hello there", "not valid JSON"},
      {std::string("\x00\x01\xff\xfe{", 5), "not valid JSON"},
      {"[\"status\"]", "expected a JSON object"},
      {R"({"cmd": "launch"})", "unknown verb"},
      {R"({"cmd": 42})", "must be a string"},
      {R"({"cmd": "status", "verbose": true})", "unexpected member"},
      {R"({"cmd": "scan", "scan": {"extent_x": 7}})", "scan.extent_x = 7: must be in [0, 1]"},
      {R"({"cmd": "scan", "scan": {"repeats": "two"}})", "scan.repeats"},
      {R"({"cmd": "scan", "scan": {"bscans_per_volume": 16}})", "fixed by the ring"},
      {R"({"cmd": "scan", "scan": {"pattern": "bidirectional", "extent_x": 1.0}})",
       "scan infeasible"},
      {R"({"cmd": "scan", "scan": {"rotation_deg": 1e400}})", "not valid JSON"},
  };
  for (const auto& [request, expected] : bad) {
    SCOPED_TRACE(request);
    const nlohmann::json reply = c.ask(request);
    ASSERT_FALSE(reply.is_discarded());
    EXPECT_EQ(reply.value("ok", true), false);
    EXPECT_NE(reply.value("error", std::string()).find(expected), std::string::npos)
        << reply.dump();
  }
  // A huge line: answered once, the rest of it ignored up to its newline.
  c.send(std::string(1 << 20, 'x') + "\n");
  const nlohmann::json huge = nlohmann::json::parse(*c.line());
  EXPECT_NE(huge["error"].get<std::string>().find("longer than 4096 bytes"), std::string::npos);
  EXPECT_EQ(c.ask(R"({"cmd":"status","id":"after"})")["id"], "after") << "still in step";

  // Too many clients: the ninth is told so and closed; the others are unaffected. The crowd
  // talks, so none of it is the silent client a newcomer may displace.
  std::vector<std::unique_ptr<Client>> crowd;
  for (int i = 0; i < 7; ++i) crowd.push_back(std::make_unique<Client>(socket_));
  for (auto& member : crowd) EXPECT_EQ(member->ask(R"({"cmd":"status"})").value("ok", false), true);
  Client extra(socket_);
  const std::optional<std::string> refused = extra.line();
  ASSERT_TRUE(refused.has_value());
  EXPECT_NE(refused->find("too many control clients"), std::string::npos);
  crowd.clear();

  // The acquisition did not notice any of it: still scanning, no fault, no miss, and groups keep
  // coming.
  const auto published = [](const nlohmann::json& reply) {
    return reply["acquisition"]["groups_published"].get<std::uint64_t>();
  };
  nlohmann::json after = status(c);
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (published(after) <= published(before) && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(10ms);
    after = status(c);
  }
  EXPECT_EQ(after["safety"]["state"], "scanning");
  EXPECT_EQ(after["safety"]["faults_total"], 0);
  EXPECT_GT(published(after), published(before));
}

TEST_F(ControlSocket, StopStartAndAScanChangeAtTheNextVolume) {
  Client c(socket_);
  ASSERT_TRUE(c.connected());
  const auto wait_state = [&](const char* state) {
    const auto end = std::chrono::steady_clock::now() + 20s;
    while (status(c)["safety"]["state"] != state && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(20ms);
    }
    return status(c)["safety"]["state"] == state;
  };
  ASSERT_TRUE(wait_state("scanning"));
  const nlohmann::json changed =
      c.ask(R"({"cmd":"scan","id":1,"scan":{"pattern":"radial","extent_x":0.5,"extent_y":0.5}})");
  EXPECT_EQ(changed["ok"], true) << changed.dump();
  EXPECT_EQ(changed["id"], 1);
  const auto end = std::chrono::steady_clock::now() + 20s;
  while (status(c)["scan"]["pattern_id"] != 4 && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(20ms);
  }
  const nlohmann::json s = status(c);
  EXPECT_EQ(s["scan"]["pattern_id"], 4) << "radial";
  EXPECT_EQ(s["scan"]["generation"], 2);
  EXPECT_EQ(s["scan"]["spec"]["pattern"], "radial");

  const nlohmann::json stopped = c.ask(R"({"cmd":"stop"})");
  EXPECT_EQ(stopped["ok"], true);
  ASSERT_TRUE(wait_state("idle"));
  EXPECT_EQ(status(c)["safety"]["emission_readback"], false);
  const nlohmann::json started = c.ask(R"({"cmd":"start"})");
  EXPECT_EQ(started["ok"], true) << started.dump();
  ASSERT_TRUE(wait_state("scanning"));
  EXPECT_EQ(status(c)["scan"]["pattern_id"], 4) << "the radial scan is kept over the re-arm";
}

// Issue F8: a control socket whose idle timeout is short enough to watch.
class ControlSocketIdle : public ControlSocket {
 protected:
  std::vector<std::string> extra_arguments() override {
    config_ = std::filesystem::temp_directory_path() /
              ("ioct-rt-idle-" + std::to_string(::getpid()) + ".toml");
    std::ofstream(config_) << "[control]\nidle_timeout_ms = 3000\nmax_clients = 8\n";
    return {"--config", config_.string()};
  }
  void TearDown() override {
    ControlSocket::TearDown();
    std::filesystem::remove(config_);
  }
  std::filesystem::path config_;
};

// Eight clients that connect and say nothing cannot lock the operator out: a newcomer takes the
// slot of the longest-silent one, and silent clients are closed after the idle timeout. A
// duplicated key is refused (the scan state does not change) and a blank line is answered.
TEST_F(ControlSocketIdle, IdleClientsCannotLockTheOperatorOut) {
  std::vector<std::unique_ptr<Client>> idle;
  for (int i = 0; i < 8; ++i) {
    idle.push_back(std::make_unique<Client>(socket_));
    ASSERT_TRUE(idle.back()->connected());
  }
  std::this_thread::sleep_for(1200ms);  // longer than kEvictAfterSilenceMs
  Client operator_client(socket_);
  const nlohmann::json reply = operator_client.ask(R"({"cmd":"status"})");
  EXPECT_EQ(reply.value("ok", false), true) << reply.dump();
  int evicted = 0;
  for (auto& c : idle) {
    if (const auto line = c->line(100ms)) {
      EXPECT_NE(line->find("longest silent"), std::string::npos) << *line;
      ++evicted;
    }
  }
  EXPECT_EQ(evicted, 1);

  // The operator's session: a duplicated key decides nothing, a blank line gets its reply.
  const std::string state_before = status(operator_client)["safety"]["state"];
  const nlohmann::json duplicate = operator_client.ask(R"({"cmd":"stop","cmd":"start"})");
  EXPECT_EQ(duplicate.value("ok", true), false);
  EXPECT_NE(duplicate.value("error", std::string()).find("given twice"), std::string::npos)
      << duplicate.dump();
  EXPECT_EQ(status(operator_client)["safety"]["state"], state_before);
  const nlohmann::json blank = operator_client.ask("");
  EXPECT_NE(blank.value("error", std::string()).find("empty line"), std::string::npos)
      << blank.dump();

  // The silent ones are closed after the idle timeout, with a reply saying why.
  int timed_out = 0;
  for (auto& c : idle) {
    if (const auto line = c->line(5s)) {
      if (line->find("idle timeout") != std::string::npos) ++timed_out;
    }
  }
  EXPECT_EQ(timed_out, 7);
}

}  // namespace
}  // namespace ioct
