#include "ioct/common/line_client.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace ioct {
namespace {

using Clock = std::chrono::steady_clock;

int millis_left(Clock::time_point end) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
  return left.count() > 0 ? static_cast<int>(left.count()) : 0;
}

}  // namespace

LineClient::LineClient(std::string socket_path, std::chrono::milliseconds timeout)
    : path_(std::move(socket_path)), timeout_(timeout) {}

LineClient::~LineClient() {
  if (fd_ >= 0) ::close(fd_);
}

void LineClient::disconnect(std::string reason) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  pending_.clear();
  error_ = std::move(reason);
}

bool LineClient::connect_now() {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path_.empty() || path_.size() >= sizeof(address.sun_path)) {
    error_ = "socket path '" + path_ + "' is empty or too long";
    return false;
  }
  std::memcpy(address.sun_path, path_.c_str(), path_.size() + 1);
  // Non-blocking from the start: a listener whose backlog is full must not stall us.
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) {
    disconnect(std::string("socket: ") + std::strerror(errno));
    return false;
  }
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    if (errno != EINPROGRESS && errno != EAGAIN) {
      disconnect("cannot connect to " + path_ + ": " + std::strerror(errno));
      return false;
    }
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, static_cast<int>(timeout_.count())) <= 0) {
      disconnect("cannot connect to " + path_ + ": timed out");
      return false;
    }
  }
  ++connections_;
  return true;
}

std::optional<std::string> LineClient::request(std::string_view line) {
  return request(line, timeout_);
}

std::optional<std::string> LineClient::request(std::string_view line,
                                               std::chrono::milliseconds timeout) {
  if (fd_ < 0 && !connect_now()) return std::nullopt;
  const Clock::time_point end = Clock::now() + timeout;
  std::string out(line);
  out.push_back('\n');
  std::size_t sent = 0;
  while (sent < out.size()) {
    const ssize_t n = ::send(fd_, out.data() + sent, out.size() - sent, MSG_NOSIGNAL);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) {
      disconnect(path_ + ": send: " + std::strerror(errno));
      return std::nullopt;
    }
    pollfd p{fd_, POLLOUT, 0};
    if (::poll(&p, 1, millis_left(end)) <= 0) {
      disconnect(path_ + ": timed out sending");
      return std::nullopt;
    }
  }
  for (;;) {
    const auto newline = pending_.find('\n');
    if (newline != std::string::npos) {
      std::string reply = pending_.substr(0, newline);
      pending_.erase(0, newline + 1);
      return reply;
    }
    if (pending_.size() > kMaxReplyBytes) {
      disconnect(path_ + ": reply longer than " + std::to_string(kMaxReplyBytes) + " bytes");
      return std::nullopt;
    }
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, millis_left(end)) <= 0) {
      disconnect(path_ + ": no reply within " + std::to_string(timeout.count()) + " ms");
      return std::nullopt;
    }
    char buffer[16384];
    const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
    if (n == 0) {
      disconnect(path_ + ": closed by the peer");
      return std::nullopt;
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      disconnect(path_ + ": recv: " + std::strerror(errno));
      return std::nullopt;
    }
    pending_.append(buffer, static_cast<std::size_t>(n));
  }
}

}  // namespace ioct
