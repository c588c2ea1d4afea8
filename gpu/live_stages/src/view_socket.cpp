#include "ioct/gpu/live_stages/view_socket.hpp"

#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "ioct/gpu/live_stages/view_requests.hpp"

namespace ioct::gpu::live {
namespace {

std::runtime_error socket_error(const std::filesystem::path& path, const std::string& what,
                                int error) {
  return std::runtime_error("view socket '" + path.string() + "': " + what + ": " +
                            std::strerror(error));
}

sockaddr_un address_of(const std::filesystem::path& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const std::string text = path.string();
  if (text.empty() || text.size() >= sizeof address.sun_path) {
    throw std::runtime_error("view socket '" + text + "': the path must be 1 to " +
                             std::to_string(sizeof address.sun_path - 1) + " bytes");
  }
  std::memcpy(address.sun_path, text.data(), text.size());
  return address;
}

// A socket file left by a process that is gone is removed; anything else stays and is refused.
void remove_stale_socket(const std::filesystem::path& path, const sockaddr_un& address) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return;  // nothing there
  if (!S_ISSOCK(st.st_mode)) {
    throw std::runtime_error("view socket '" + path.string() + "': exists and is not a socket");
  }
  const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (probe < 0) throw socket_error(path, "socket", errno);
  const bool live =
      ::connect(probe, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0;
  const int error = errno;
  ::close(probe);
  if (live) {
    throw std::runtime_error("view socket '" + path.string() + "': another process serves it");
  }
  if (error != ECONNREFUSED) throw socket_error(path, "probing the old socket", error);
  ::unlink(path.c_str());
}

struct Client {
  int fd = -1;
  std::string in;
  std::string out;
  bool closing = false;  // no more requests: flush the replies, then close
};

}  // namespace

ViewSocket::ViewSocket(ViewSocketConfig config, ViewControl& control)
    : config_(std::move(config)), control_(control) {
  const sockaddr_un address = address_of(config_.path);
  remove_stale_socket(config_.path, address);
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listen_fd_ < 0) throw socket_error(config_.path, "socket", errno);
  stop_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (stop_fd_ < 0 ||
      ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::chmod(config_.path.c_str(), config_.mode) != 0 || ::listen(listen_fd_, 8) != 0) {
    const int error = errno;
    if (stop_fd_ >= 0) ::close(stop_fd_);
    ::close(listen_fd_);
    throw socket_error(config_.path, "cannot listen", error);
  }
  if (!config_.group.empty()) {
    // ioct-view runs as another user: it reaches the socket through this group.
    const group* g = ::getgrnam(config_.group.c_str());
    if (g == nullptr || ::chown(config_.path.c_str(), static_cast<uid_t>(-1), g->gr_gid) != 0) {
      const int error = g == nullptr ? ENOENT : errno;
      ::close(stop_fd_);
      ::close(listen_fd_);
      ::unlink(config_.path.c_str());
      throw socket_error(config_.path, "cannot give it the group '" + config_.group + "'", error);
    }
  }
  thread_ = std::thread([this] { serve(); });
}

ViewSocket::~ViewSocket() {
  const std::uint64_t one = 1;
  (void)!::write(stop_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  ::close(listen_fd_);
  ::close(stop_fd_);
  ::unlink(config_.path.c_str());
}

void ViewSocket::serve() {
  ViewRequests requests(control_, config_.snapshot_dir, config_.snapshot_timeout);
  std::map<std::uint64_t, Client> clients;
  std::uint64_t next_client = 1;
  const auto reply = [&](Client& client, const nlohmann::json& message) {
    client.out += message.dump();
    client.out += '\n';
  };

  for (;;) {
    std::vector<pollfd> fds{{stop_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}};
    std::vector<std::uint64_t> ids;
    for (const auto& [id, client] : clients) {
      short events = client.closing ? 0 : POLLIN;
      if (!client.out.empty()) events |= POLLOUT;
      fds.push_back({client.fd, events, 0});
      ids.push_back(id);
    }
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (fds[0].revents != 0) break;

    for (std::size_t i = 0; i < ids.size(); ++i) {
      Client& client = clients.at(ids[i]);
      const short revents = fds[i + 2].revents;
      bool gone = (revents & (POLLERR | POLLNVAL)) != 0;
      if (!gone && (revents & (POLLIN | POLLHUP)) != 0 && !client.closing) {
        char chunk[8192];
        const ssize_t n = ::recv(client.fd, chunk, sizeof chunk, 0);
        if (n > 0) {
          client.in.append(chunk, static_cast<std::size_t>(n));
        } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
          gone = true;
        }
        // Every complete line gets its reply, in order.
        std::size_t start = 0;
        for (std::size_t end;
             !client.closing && (end = client.in.find('\n', start)) != std::string::npos;
             start = end + 1) {
          std::string_view line(client.in.data() + start, end - start);
          if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
          if (line.size() > config_.max_line_bytes) {
            client.closing = true;
          } else if (line.find_first_not_of(" \t") != std::string_view::npos) {
            reply(client, requests.handle(line, ids[i]));
          }
        }
        client.in.erase(0, start);
        if (client.closing || client.in.size() > config_.max_line_bytes) {
          // The rest of the stream cannot be told apart from the oversized line: say so, stop.
          client.closing = true;
          client.in.clear();
          reply(client, {{"ok", false},
                         {"error", "line longer than " + std::to_string(config_.max_line_bytes) +
                                       " bytes; closing"},
                         {"key", "request"}});
        }
      }
      if (!gone && !client.out.empty()) {
        const ssize_t n =
            ::send(client.fd, client.out.data(), client.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n > 0) {
          client.out.erase(0, static_cast<std::size_t>(n));
        } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
          gone = true;
        }
        if (client.out.size() > config_.max_unsent_bytes) gone = true;  // it does not read
      }
      if (!gone && client.closing && client.out.empty()) gone = true;
      if (gone) {
        ::close(client.fd);
        requests.client_gone(ids[i]);
        clients.erase(ids[i]);
      }
    }
    // After the clients: one that just went makes room for one that comes.
    if ((fds[1].revents & POLLIN) != 0) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (fd >= 0) {
        Client client;
        client.fd = fd;
        if (clients.size() >= config_.max_clients) {
          reply(client, {{"ok", false},
                         {"error",
                          "too many clients (at most " + std::to_string(config_.max_clients) + ")"},
                         {"key", "request"}});
          (void)!::send(fd, client.out.data(), client.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
          ::close(fd);
        } else {
          clients.emplace(next_client++, std::move(client));
        }
      }
    }
  }
  for (auto& [id, client] : clients) {
    ::close(client.fd);
    requests.client_gone(id);
  }
}

}  // namespace ioct::gpu::live
