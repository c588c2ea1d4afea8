#include "ioct/test_support/child_process.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <cerrno>
#include <chrono>

namespace ioct::test_support {
namespace {

using std::chrono::milliseconds;

TEST(ChildProcess, ReadsLinesAndExitStatus) {
  ChildProcess child =
      ChildProcess::spawn("/bin/sh", {"-c", "echo first; printf 'second\\nthird'; exit 3"});
  EXPECT_EQ(child.read_line(milliseconds(5000)), "first");
  EXPECT_EQ(child.read_line(milliseconds(5000)), "second");
  // "third" has no newline: it is not a complete line.
  EXPECT_EQ(child.read_line(milliseconds(5000)), std::nullopt);
  const auto status = child.wait_for(milliseconds(5000));
  ASSERT_TRUE(status.has_value());
  EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 3) << describe_wait_status(*status);
}

TEST(ChildProcess, ReadLineTimesOutWhileTheChildIsSilent) {
  ChildProcess child = ChildProcess::spawn("/bin/sh", {"-c", "exec sleep 30"});
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(child.read_line(milliseconds(100)), std::nullopt);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  EXPECT_EQ(child.wait_for(milliseconds(10)), std::nullopt);
  const int status = child.kill_and_wait();
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << describe_wait_status(status);
}

TEST(ChildProcess, DestructorKillsAndReapsARunningChild) {
  pid_t pid = -1;
  {
    ChildProcess child = ChildProcess::spawn("/bin/sh", {"-c", "exec sleep 30"});
    pid = child.pid();
    ASSERT_EQ(::kill(pid, 0), 0);
  }
  errno = 0;
  EXPECT_EQ(::kill(pid, 0), -1);
  EXPECT_EQ(errno, ESRCH);
}

TEST(ChildProcess, SpawnOfAMissingProgramThrows) {
  EXPECT_THROW(ChildProcess::spawn("/nonexistent/program", {}), std::system_error);
}

TEST(SiblingExecutable, FindsExecutablesBesideTheTestOnly) {
  EXPECT_NO_THROW(sibling_executable("test_support_tests"));
  EXPECT_THROW(sibling_executable("no-such-executable"), std::runtime_error);
}

}  // namespace
}  // namespace ioct::test_support
