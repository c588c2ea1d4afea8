// ViewSocket: the requests over a real Unix socket, one reply line per request line in order;
// oversized lines, too many clients, a stale socket file and a file that is not a socket.
#include <gtest/gtest.h>

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "ioct/gpu/live_stages/view_socket.hpp"
#include "recording_control.hpp"

namespace ioct::gpu::live {
namespace {

using nlohmann::json;

// A client connection with a line reader and a deadline on every read.
class Connection {
 public:
  explicit Connection(const std::filesystem::path& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  }
  ~Connection() { ::close(fd_); }
  bool connected() const { return connected_; }
  void send_text(const std::string& text) {
    std::size_t sent = 0;
    while (sent < text.size()) {
      const ssize_t n = ::send(fd_, text.data() + sent, text.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return;  // the server closed: the test reads why
      sent += static_cast<std::size_t>(n);
    }
  }
  // The next line, or "" at end of stream or after 5 s.
  std::string read_line() {
    for (;;) {
      if (const auto end = buffer_.find('\n'); end != std::string::npos) {
        std::string line = buffer_.substr(0, end);
        buffer_.erase(0, end + 1);
        return line;
      }
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 5000) <= 0) return "";
      char chunk[4096];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) return "";
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }
  json ask(const std::string& line) {
    send_text(line + "\n");
    const std::string reply = read_line();
    return reply.empty() ? json(nullptr) : json::parse(reply);
  }
  bool closed_by_server() {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 5000) <= 0) return false;
    char c;
    return ::recv(fd_, &c, 1, 0) == 0;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  std::string buffer_;
};

class ViewSocketTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(dir_);
    config_.path = dir_ / "view.sock";
    config_.snapshot_dir = dir_ / "snapshots";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  const std::filesystem::path dir_ =
      std::filesystem::temp_directory_path() /
      ("ioct-vs-" + std::to_string(::getpid()) + "-" +
       ::testing::UnitTest::GetInstance()->current_test_info()->name());
  ViewSocketConfig config_;
  RecordingControl control_;
};

TEST_F(ViewSocketTest, AnswersEachRequestInOrder) {
  ViewSocket socket(config_, control_);
  Connection client(config_.path);
  ASSERT_TRUE(client.connected());
  EXPECT_EQ(client.ask(R"({"cmd":"get"})").at("generation"), 1);
  // Two requests in one write, answered in order.
  client.send_text(R"({"cmd":"set","changes":{"enhanced":{"threshold":0.6}}})"
                   "\n"
                   R"({"cmd":"get"})"
                   "\r\n\n");
  EXPECT_EQ(json::parse(client.read_line()), json({{"ok", true}, {"generation", 2}}));
  EXPECT_EQ(json::parse(client.read_line()).at("params").at("enhanced").at("threshold"), 0.6);
  EXPECT_EQ(client.ask(R"({"cmd":"open_view","view":2})"), json({{"ok", true}, {"view", 2}}));
  EXPECT_EQ(client.ask(R"({"cmd":"set","view":2,"changes":{"view":{"zoom":2}}})").at("ok"), true);
  EXPECT_EQ(client.ask(R"({"cmd":"close_view","view":2})"), json({{"ok", true}}));
  const json shot = client.ask(R"({"cmd":"snapshot","name":"s1"})");
  ASSERT_EQ(shot.at("ok"), true) << shot;
  EXPECT_TRUE(std::filesystem::exists(config_.snapshot_dir / "s1.png"));
}

TEST_F(ViewSocketTest, BadLinesGetErrorRepliesAndTheConnectionGoesOn) {
  ViewSocket socket(config_, control_);
  Connection client(config_.path);
  for (const char* line :
       {"{oops", R"({"cmd":"get","cmd":"get"})", R"({"cmd":"launch"})",
        R"({"cmd":"set","changes":{"enhanced":{"kg1":-1}}})", R"({"cmd":"snapshot","name":"../x"})",
        R"({"cmd":"snapshot","name":"/abs"})", R"({"cmd":"snapshot","name":""})"}) {
    const json reply = client.ask(line);
    ASSERT_TRUE(reply.is_object()) << line;
    EXPECT_EQ(reply.at("ok"), false) << line;
    EXPECT_TRUE(reply.contains("key")) << line;
  }
  EXPECT_EQ(client.ask(R"({"cmd":"get"})").at("ok"), true);
  std::lock_guard lock(control_.mutex);
  EXPECT_EQ(control_.generation, 1u);
  EXPECT_EQ(control_.snapshots, 0);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "x.png"));
}

TEST_F(ViewSocketTest, AnOversizedLineIsRefusedAndTheClientClosed) {
  config_.max_line_bytes = 1024;
  ViewSocket socket(config_, control_);
  Connection client(config_.path);
  client.send_text(R"({"cmd":"set","changes":{"mode":")" + std::string(4096, 'a'));
  const json reply = json::parse(client.read_line());
  EXPECT_EQ(reply.at("ok"), false);
  EXPECT_NE(reply.at("error").get<std::string>().find("longer than 1024"), std::string::npos);
  EXPECT_TRUE(client.closed_by_server());
  // Others are served as before.
  Connection other(config_.path);
  EXPECT_EQ(other.ask(R"({"cmd":"get"})").at("ok"), true);
}

TEST_F(ViewSocketTest, ClientsAreBoundedAndTheirViewsCloseWithThem) {
  config_.max_clients = 2;
  ViewSocket socket(config_, control_);
  {
    Connection a(config_.path);
    Connection b(config_.path);
    ASSERT_EQ(a.ask(R"({"cmd":"open_view","view":9})").at("ok"), true);
    ASSERT_EQ(b.ask(R"({"cmd":"get"})").at("ok"), true);
    Connection c(config_.path);
    const json refused = json::parse(c.read_line());
    EXPECT_EQ(refused.at("ok"), false);
    EXPECT_NE(refused.at("error").get<std::string>().find("too many clients"), std::string::npos);
    EXPECT_TRUE(c.closed_by_server());
  }
  // a and b are gone: a's view is closed, and there is room again.
  Connection d(config_.path);
  EXPECT_EQ(d.ask(R"({"cmd":"get"})").at("ok"), true);
  std::lock_guard lock(control_.mutex);
  EXPECT_FALSE(control_.open.contains(9));
}

TEST_F(ViewSocketTest, AStaleSocketFileIsReplacedAnythingElseRefused) {
  {
    ViewSocket first(config_, control_);
    EXPECT_THROW(ViewSocket(config_, control_), std::runtime_error);  // a live server owns it
  }
  EXPECT_FALSE(std::filesystem::exists(config_.path));  // removed on the way out
  // A socket file left behind by a process that died.
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, config_.path.c_str(), sizeof address.sun_path - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ::close(fd);
  {
    ViewSocket replaced(config_, control_);
    Connection client(config_.path);
    EXPECT_EQ(client.ask(R"({"cmd":"get"})").at("ok"), true);
  }
  std::ofstream(config_.path) << "not a socket";
  EXPECT_THROW(ViewSocket(config_, control_), std::runtime_error);
  EXPECT_TRUE(std::filesystem::is_regular_file(config_.path));  // left alone
}

}  // namespace
}  // namespace ioct::gpu::live
