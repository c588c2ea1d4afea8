#include "line_service.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <stdexcept>

namespace ioct::view::testing {

LineService::LineService(std::string path, Handler handler)
    : path_(std::move(path)), handler_(std::move(handler)) {
  ::unlink(path_.c_str());
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, path_.c_str(), sizeof address.sun_path - 1);
  if (::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(listen_fd_, 8) != 0) {
    throw std::runtime_error("test line service: cannot listen on " + path_);
  }
  thread_ = std::thread([this] { serve(); });
}

LineService::~LineService() {
  stop_ = true;
  thread_.join();
  ::close(listen_fd_);
  ::unlink(path_.c_str());
}

std::vector<nlohmann::json> LineService::requests() const {
  std::lock_guard lock(mutex_);
  return requests_;
}

void LineService::serve() {
  std::vector<std::pair<int, std::string>> clients;
  while (!stop_) {
    std::vector<pollfd> fds{{listen_fd_, POLLIN, 0}};
    for (const auto& c : clients) fds.push_back({c.first, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), 20) <= 0) continue;
    if (fds[0].revents & POLLIN) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) clients.push_back({fd, {}});
    }
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (!(fds[i].revents & (POLLIN | POLLHUP))) continue;
      auto& [fd, in] = clients[i - 1];
      char buffer[4096];
      const ssize_t n = ::read(fd, buffer, sizeof buffer);
      if (n <= 0) {
        ::close(fd);
        fd = -1;
        continue;
      }
      in.append(buffer, static_cast<std::size_t>(n));
      for (auto nl = in.find('\n'); nl != std::string::npos; nl = in.find('\n')) {
        const nlohmann::json request = nlohmann::json::parse(in.substr(0, nl), nullptr, false);
        in.erase(0, nl + 1);
        {
          std::lock_guard lock(mutex_);
          requests_.push_back(request);
        }
        const std::string reply = handler_(request).dump() + "\n";
        (void)!::write(fd, reply.data(), reply.size());
      }
    }
    std::erase_if(clients, [](const auto& c) { return c.first < 0; });
  }
  for (const auto& c : clients) ::close(c.first);
}

}  // namespace ioct::view::testing
