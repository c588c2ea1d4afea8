#include "ioct/view_test/logged_process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace ioct::view_test {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

LoggedProcess::LoggedProcess(std::string program, std::vector<std::string> arguments,
                             std::filesystem::path log_file)
    : program_(std::move(program)),
      arguments_(std::move(arguments)),
      log_file_(std::move(log_file)) {}

LoggedProcess::~LoggedProcess() {
  if (pid_ > 0) stop(std::chrono::milliseconds(2000));
}

void LoggedProcess::start() {
  if (running()) throw std::runtime_error(describe() + " is already running");
  std::vector<std::string> argv_strings{program_};
  argv_strings.insert(argv_strings.end(), arguments_.begin(), arguments_.end());
  std::vector<char*> argv;
  for (std::string& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_file_.c_str(),
                                     O_WRONLY | O_CREAT | O_APPEND, 0644);
  ::posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  ::posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  pid_t pid = -1;
  const int rc = ::posix_spawn(&pid, program_.c_str(), &actions, nullptr, argv.data(), environ);
  ::posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error("cannot start " + program_ + ": " + std::strerror(rc));
  pid_ = pid;
  exit_status_.reset();
}

std::optional<int> LoggedProcess::stop(std::chrono::milliseconds grace) {
  if (!running()) return std::nullopt;
  ::kill(pid_, SIGCONT);  // a paused process cannot act on SIGTERM
  ::kill(pid_, SIGTERM);
  const auto deadline = Clock::now() + grace;
  while (Clock::now() < deadline) {
    if (!running()) return exit_status_;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ::kill(pid_, SIGKILL);
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  exit_status_ = status;
  return status;
}

void LoggedProcess::signal(int signal_number) const {
  if (pid_ <= 0) throw std::logic_error(describe() + " is not running");
  ::kill(pid_, signal_number);
}

bool LoggedProcess::running() {
  if (pid_ <= 0) return false;
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) == pid_) {
    pid_ = -1;
    exit_status_ = status;
    return false;
  }
  return true;
}

std::string LoggedProcess::log_tail(std::size_t bytes) const {
  std::ifstream in(log_file_, std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return all.size() > bytes ? all.substr(all.size() - bytes) : all;
}

std::string LoggedProcess::describe() const {
  std::string text = std::filesystem::path(program_).filename().string();
  for (const std::string& a : arguments_) text += " " + a;
  if (pid_ > 0) text += " (pid " + std::to_string(pid_) + ")";
  return text;
}

}  // namespace ioct::view_test
