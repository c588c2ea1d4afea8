// The view socket: a Unix stream socket on which ioct-view (or a script) sends render-parameter
// requests, one JSON object per line, and gets one reply line per request, in order
// (ViewRequests says what they are). It runs on a thread of its own and never touches the
// pipeline except through ViewControl, so nothing a client sends or fails to read can stall a
// pass: lines are bounded, clients are bounded, replies to a client that does not read are
// dropped with the client.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <string>
#include <thread>

#include "ioct/gpu/live_stages/view_control.hpp"

namespace ioct::gpu::live {

struct ViewSocketConfig {
  std::filesystem::path path;          // the socket's file
  std::filesystem::path snapshot_dir;  // snapshots are written here, and nowhere else
  std::size_t max_line_bytes = 64 * 1024;
  std::size_t max_clients = 4;
  std::size_t max_unsent_bytes = 1 << 20;  // replies a client has not read: more closes it
  std::chrono::milliseconds snapshot_timeout{10000};
  unsigned mode = 0660;  // the view's group connects
  std::string group;     // the socket file's group (ioct-view's); empty: this process's
};

class ViewSocket {
 public:
  // Binds and listens, then serves on a thread of its own. A stale socket file (nobody accepts
  // on it) is replaced; a live one or any other file is refused. Throws std::runtime_error naming
  // the path and the reason.
  ViewSocket(ViewSocketConfig config, ViewControl& control);
  ~ViewSocket();  // stops serving, closes every client and removes the socket file
  ViewSocket(const ViewSocket&) = delete;
  ViewSocket& operator=(const ViewSocket&) = delete;

  const std::filesystem::path& path() const noexcept { return config_.path; }

 private:
  void serve();

  ViewSocketConfig config_;
  ViewControl& control_;
  int listen_fd_ = -1;
  int stop_fd_ = -1;  // eventfd: the destructor's wake-up
  std::thread thread_;
};

}  // namespace ioct::gpu::live
