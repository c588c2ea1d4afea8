#include "ioct/test_support/bounded_child.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <thread>

namespace ioct::test_support {

std::string to_string(ChildOutcome outcome) {
  switch (outcome) {
    case ChildOutcome::passed:
      return "passed";
    case ChildOutcome::failed:
      return "failed";
    case ChildOutcome::hung:
      return "hung (killed at the time limit)";
  }
  return "?";
}

ChildOutcome run_in_child(const std::function<bool()>& action, ChildLimits limits) {
  const pid_t child = ::fork();
  if (child < 0) return ChildOutcome::failed;
  if (child == 0) {
    if (limits.data_bytes != 0) {
      const rlimit limit{limits.data_bytes, limits.data_bytes};
      if (::setrlimit(RLIMIT_DATA, &limit) != 0) ::_exit(3);
    }
    bool ok = false;
    try {
      ok = action();
    } catch (...) {
    }
    ::_exit(ok ? 0 : 1);
  }
  const auto give_up = std::chrono::steady_clock::now() + limits.time;
  int status = 0;
  while (::waitpid(child, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > give_up) {
      ::kill(child, SIGKILL);
      ::waitpid(child, &status, 0);
      return ChildOutcome::hung;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? ChildOutcome::passed
                                                       : ChildOutcome::failed;
}

}  // namespace ioct::test_support
