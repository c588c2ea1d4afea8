// The one log sink: the line format, lines whole from several threads, and the journal's priority
// when standard error is the journal.
#include "ioct/common/log.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "ioct/test_support/temp_path.hpp"

namespace ioct {
namespace {

TEST(Log, NamesTheProgramAndLabelsWarningsAndErrors) {
  std::ostringstream out;
  const Log log("ioct-test", out);
  log.info("scanning");
  log.warning("2 of 4 workers without SCHED_FIFO");
  log.error("acquisition failed: digitizer timeout");
  EXPECT_EQ(out.str(),
            "ioct-test: scanning\n"
            "ioct-test: warning: 2 of 4 workers without SCHED_FIFO\n"
            "ioct-test: error: acquisition failed: digitizer timeout\n");
}

TEST(Log, LinesFromSeveralThreadsArriveWholeAndNoneIsLost) {
  std::ostringstream out;
  const Log log("ioct-test", out);
  constexpr int kThreads = 4;
  constexpr int kLines = 2000;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&log, t] {
      for (int i = 0; i < kLines; ++i) {
        log.info("thread " + std::to_string(t) + " line " + std::to_string(i) + " end");
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  std::istringstream in(out.str());
  std::set<std::string> seen;
  for (std::string line; std::getline(in, line);) {
    ASSERT_EQ(line.rfind("ioct-test: thread ", 0), 0u) << line;
    ASSERT_EQ(line.substr(line.size() - 4), " end") << line;
    seen.insert(line);
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(kThreads * kLines));
}

// Standard error redirected to a file for the test's duration.
class StderrInFile {
 public:
  explicit StderrInFile(const std::filesystem::path& file)
      : saved_(::dup(STDERR_FILENO)),
        fd_(::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600)) {
    ::fflush(stderr);
    ::dup2(fd_, STDERR_FILENO);
  }
  StderrInFile(const StderrInFile&) = delete;
  StderrInFile& operator=(const StderrInFile&) = delete;
  ~StderrInFile() {
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    ::close(fd_);
  }
  // "device:inode" of the file, as systemd sets JOURNAL_STREAM.
  std::string journal_stream() const {
    struct stat st {};
    ::fstat(fd_, &st);
    return std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
  }

 private:
  int saved_;
  int fd_;
};

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Log, OnTheJournalEachLineCarriesItsPriority) {
  const test_support::TempPath file("log-journal");
  {
    const StderrInFile redirected(file.path());
    ::setenv("JOURNAL_STREAM", redirected.journal_stream().c_str(), 1);
    EXPECT_TRUE(stderr_is_journal());
    const Log log("ioct-test");
    log.info("scanning");
    log.warning("fell back to the CPU");
    log.error("device lost");
    ::unsetenv("JOURNAL_STREAM");
  }
  EXPECT_EQ(read_text(file.path()),
            "<6>ioct-test: scanning\n"
            "<4>ioct-test: warning: fell back to the CPU\n"
            "<3>ioct-test: error: device lost\n");
}

TEST(Log, StandardErrorThatIsNotTheJournalGetsPlainLines) {
  const test_support::TempPath file("log-plain");
  {
    const StderrInFile redirected(file.path());
    // The journal's stream is another file (a child of a service that redirected its stderr).
    ::setenv("JOURNAL_STREAM", "1:1", 1);
    EXPECT_FALSE(stderr_is_journal());
    Log("ioct-test").warning("no GPU");
    ::unsetenv("JOURNAL_STREAM");
  }
  EXPECT_EQ(read_text(file.path()), "ioct-test: warning: no GPU\n");
}

}  // namespace
}  // namespace ioct
