// A stand-in for ioct-gpu's view socket or ioct-rt's control socket: a Unix socket that answers
// each request line through a handler and remembers what it was asked.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

namespace ioct::view::testing {

class LineService {
 public:
  using Handler = std::function<nlohmann::json(const nlohmann::json& request)>;
  LineService(std::string path, Handler handler);
  ~LineService();

  std::vector<nlohmann::json> requests() const;
  const std::string& path() const noexcept { return path_; }

 private:
  void serve();
  std::string path_;
  Handler handler_;
  int listen_fd_ = -1;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<nlohmann::json> requests_;
  std::thread thread_;
};

}  // namespace ioct::view::testing
