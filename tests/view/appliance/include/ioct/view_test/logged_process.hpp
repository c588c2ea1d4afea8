// A process a test starts and stops at will, its stdout and stderr appended to a log file (kept
// with the test's artefacts, and long-running peers never block on a full pipe). Stopping sends
// SIGTERM, then SIGKILL after a grace period; destroying it kills what still runs.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace ioct::view_test {

class LoggedProcess {
 public:
  LoggedProcess(std::string program, std::vector<std::string> arguments,
                std::filesystem::path log_file);
  ~LoggedProcess();
  LoggedProcess(const LoggedProcess&) = delete;
  LoggedProcess& operator=(const LoggedProcess&) = delete;

  // Starts it (again); throws std::runtime_error when it is already running or cannot start.
  void start();
  // SIGTERM, then SIGKILL once `grace` passes; returns the wait status, nullopt if not running.
  std::optional<int> stop(std::chrono::milliseconds grace = std::chrono::milliseconds(5000));
  void signal(int signal_number) const;
  // Whether it is still running (reaps it if it ended).
  bool running();
  // The wait status of its last end, once it ended.
  std::optional<int> exit_status() const noexcept { return exit_status_; }

  pid_t pid() const noexcept { return pid_; }
  const std::filesystem::path& log_file() const noexcept { return log_file_; }
  std::string log_tail(std::size_t bytes = 3000) const;
  // "ioct-rt --ring ... (pid 123)"
  std::string describe() const;

 private:
  std::string program_;
  std::vector<std::string> arguments_;
  std::filesystem::path log_file_;
  pid_t pid_ = -1;
  std::optional<int> exit_status_;
};

}  // namespace ioct::view_test
