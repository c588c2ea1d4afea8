#include "ioct/common/line_server.hpp"

#include <fcntl.h>
#include <grp.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct {
namespace {

std::string errno_text(int error) {
  return std::strerror(error);
}

sockaddr_un address_of(const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(address.sun_path)) {
    throw std::runtime_error("socket path \"" + path + "\" must be 1 to " +
                             std::to_string(sizeof(address.sun_path) - 1) + " bytes long");
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  return address;
}

// True when something accepts connections on `path` (another server).
bool answered(const sockaddr_un& address) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) == 0;
  ::close(fd);
  return ok;
}

}  // namespace

std::string error_reply(const std::string& message, const nlohmann::json& id,
                        std::string_view cmd) {
  nlohmann::json reply = {{"ok", false}, {"error", message}};
  if (!cmd.empty()) reply["cmd"] = std::string(cmd);
  if (!id.is_null()) reply["id"] = id;
  return reply.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

LineServer::LineServer(std::string path, const std::string& group, std::uint32_t max_clients,
                       std::uint64_t idle_timeout_ms, LineServerNames names)
    : path_(std::move(path)),
      names_(std::move(names)),
      max_clients_(max_clients),
      idle_timeout_ns_(idle_timeout_ms * 1'000'000u) {
  const sockaddr_un address = address_of(path_);
  gid_t gid = static_cast<gid_t>(-1);
  if (!group.empty()) {
    const ::group* g = ::getgrnam(group.c_str());
    if (g == nullptr) {
      throw std::runtime_error(names_.socket + " " + path_ + ": no group \"" + group + "\" (" +
                               names_.group_key + ")");
    }
    gid = g->gr_gid;
  }
  struct stat existing {};
  if (::lstat(path_.c_str(), &existing) == 0) {
    if (!S_ISSOCK(existing.st_mode)) {
      throw std::runtime_error(names_.socket + " " + path_ +
                               " exists and is not a socket; not replacing it");
    }
    if (answered(address)) {
      throw std::runtime_error(names_.socket + " " + path_ +
                               " is in use by a running process (another " + names_.owner + "?)");
    }
    ::unlink(path_.c_str());  // a stale socket of a process that is gone
  }
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) throw std::runtime_error(names_.socket + ": socket(): " + errno_text(errno));
  // No moment with wider permissions than 0660: the umask covers bind(), chmod() makes it exact.
  const mode_t old_mask = ::umask(0117);
  const int bound =
      ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), sizeof(address));
  const int bind_error = errno;
  ::umask(old_mask);
  if (bound != 0) {
    ::close(listen_fd_);
    throw std::runtime_error(names_.socket + " " + path_ + ": bind(): " + errno_text(bind_error));
  }
  if (::chmod(path_.c_str(), 0660) != 0 ||
      (gid != static_cast<gid_t>(-1) && ::chown(path_.c_str(), static_cast<uid_t>(-1), gid) != 0) ||
      ::listen(listen_fd_, 8) != 0) {
    const int error = errno;
    ::close(listen_fd_);
    ::unlink(path_.c_str());
    throw std::runtime_error(names_.socket + " " + path_ + ": " + errno_text(error) +
                             (group.empty() ? "" : " (group " + group + ")"));
  }
}

LineServer::~LineServer() {
  for (Client& c : clients_) ::close(c.fd);
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    ::unlink(path_.c_str());
  }
}

void LineServer::add_poll_fds(std::vector<pollfd>& fds) const {
  fds.push_back({listen_fd_, POLLIN, 0});
  for (const Client& c : clients_) {
    const short events =
        static_cast<short>((c.closing ? 0 : POLLIN) | (c.out.empty() ? 0 : POLLOUT));
    fds.push_back({c.fd, events, 0});
  }
}

void LineServer::process(const pollfd* fds, std::size_t count, const Handler& handler) {
  const std::uint64_t now = monotonic_ns();
  // fds[0] is the listener, fds[1 + i] client i, as add_poll_fds() laid them out.
  std::vector<bool> drop(clients_.size(), false);
  for (std::size_t i = 0; i + 1 < count && i < clients_.size(); ++i) {
    const short revents = fds[1 + i].revents;
    Client& client = clients_[i];
    if ((revents & (POLLIN | POLLHUP | POLLERR)) != 0 && !client.closing) {
      if (!read_from(client, handler)) drop[i] = true;
    }
    if (!drop[i] && !client.out.empty() && !write_to(client)) drop[i] = true;
    if (!drop[i] && client.closing && client.out.empty()) drop[i] = true;
  }
  close_idle(now, drop);
  for (std::size_t i = clients_.size(); i-- > 0;) {
    if (i < drop.size() && drop[i]) {
      ::close(clients_[i].fd);
      clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(i));
    }
  }
  if (count > 0 && (fds[0].revents & POLLIN) != 0) accept_clients(now);
}

void LineServer::close_idle(std::uint64_t now_ns, std::vector<bool>& drop) {
  for (std::size_t i = 0; i < clients_.size() && i < drop.size(); ++i) {
    Client& c = clients_[i];
    // last_heard_ns may be a little after now_ns (a line read during this pass).
    if (drop[i] || c.last_heard_ns + idle_timeout_ns_ > now_ns) continue;
    const std::string reply =
        error_reply("closing: no request for " + std::to_string(idle_timeout_ns_ / 1'000'000) +
                    " ms (the idle timeout)") +
        "\n";
    (void)!::send(c.fd, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    drop[i] = true;
    ++closed_idle_;
  }
}

bool LineServer::evict_silent(std::uint64_t now_ns) {
  std::size_t silent = clients_.size();
  for (std::size_t i = 0; i < clients_.size(); ++i) {
    if (silent == clients_.size() || clients_[i].last_heard_ns < clients_[silent].last_heard_ns) {
      silent = i;
    }
  }
  if (silent == clients_.size() ||
      clients_[silent].last_heard_ns + kEvictAfterSilenceMs * 1'000'000u > now_ns) {
    return false;
  }
  const std::string reply =
      error_reply(
          "closing: every control slot is taken and this connection was the longest "
          "silent; reconnect to send a command") +
      "\n";
  (void)!::send(clients_[silent].fd, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::close(clients_[silent].fd);
  clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(silent));
  ++closed_idle_;
  return true;
}

void LineServer::accept_clients(std::uint64_t now_ns) {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // EAGAIN: none left (or a transient error: the next poll retries)
    if (clients_.size() >= max_clients_ && !evict_silent(now_ns)) {
      ++rejected_;
      const std::string reply =
          error_reply("too many control clients (" + names_.max_clients_key + " = " +
                      std::to_string(max_clients_) + "); try again later") +
          "\n";
      (void)!::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      ::close(fd);
      continue;
    }
    clients_.push_back(Client{fd, {}, {}, false, false, now_ns});
  }
}

bool LineServer::read_from(Client& client, const Handler& handler) {
  char buffer[8192];
  // Bounded work per wake-up, so one client cannot hold the housekeeping loop.
  for (int rounds = 0; rounds < 8; ++rounds) {
    const ssize_t got = ::recv(client.fd, buffer, sizeof(buffer), MSG_DONTWAIT);
    if (got == 0) {
      // The client closed its side: answer what it sent, then close.
      client.closing = true;
      return true;
    }
    if (got < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    for (ssize_t i = 0; i < got; ++i) {
      const char c = buffer[i];
      if (c == '\n') {
        if (client.discarding) {
          client.discarding = false;
          continue;
        }
        std::string line = std::move(client.in);
        client.in.clear();
        if (!line.empty() && line.back() == '\r') line.pop_back();
        // Every line gets its reply, a blank one included (an error saying it is empty).
        ++requests_;
        client.last_heard_ns = monotonic_ns();
        client.out += handler(line);
        client.out += '\n';
        continue;
      }
      if (client.discarding) continue;
      client.in += c;
      if (client.in.size() > kMaxControlLineBytes) {
        client.in.clear();
        client.discarding = true;
        ++requests_;
        client.out += error_reply("line longer than " + std::to_string(kMaxControlLineBytes) +
                                  " bytes; ignored up to its newline") +
                      "\n";
      }
    }
    if (client.out.size() > kMaxPendingReplyBytes) return false;  // it does not read its replies
  }
  return true;
}

bool LineServer::write_to(Client& client) {
  while (!client.out.empty()) {
    const ssize_t sent =
        ::send(client.fd, client.out.data(), client.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (sent < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    client.out.erase(0, static_cast<std::size_t>(sent));
  }
  return true;
}

}  // namespace ioct
