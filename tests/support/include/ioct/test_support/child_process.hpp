// A child process started from an executable built beside the test (posix_spawn), whose stdout
// the test reads line by line. Multi-process tests use it to run peers they can kill.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace ioct::test_support {

class ChildProcess {
 public:
  // Starts `program` (a path) with `arguments`. Its stdout is a pipe read by read_line(); its
  // stderr is ours, so a failing child explains itself in the test log. Throws
  // std::system_error when the process cannot be started.
  static ChildProcess spawn(const std::string& program, const std::vector<std::string>& arguments);

  ChildProcess(ChildProcess&& other) noexcept;
  ChildProcess& operator=(ChildProcess&&) = delete;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  // A child still running is killed (SIGKILL) and reaped: a failed test leaves no process behind.
  ~ChildProcess();

  pid_t pid() const noexcept { return pid_; }

  // The next line the child wrote, without its newline; nullopt when none arrives in `timeout`
  // or the child closed its stdout.
  std::optional<std::string> read_line(std::chrono::milliseconds timeout);

  void send_signal(int signal_number) const;

  // Waits for the child to end and reaps it. Returns the wait status (see describe_wait_status),
  // or nullopt if it is still running after `timeout`.
  std::optional<int> wait_for(std::chrono::milliseconds timeout);

  // Sends SIGKILL and reaps; returns the wait status.
  int kill_and_wait();

 private:
  ChildProcess(pid_t pid, int stdout_fd) noexcept : pid_(pid), stdout_fd_(stdout_fd) {}

  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  bool reaped_ = false;
  std::string pending_;  // bytes read past the last complete line
};

// "exited with status 0", "killed by signal 9 (Killed)", ...
std::string describe_wait_status(int status);

// The path of executable `name` in the directory of the running executable (/proc/self/exe).
// Throws std::runtime_error when there is no such executable.
std::string sibling_executable(const std::string& name);

}  // namespace ioct::test_support
