#include "ioct/common/log.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <ostream>
#include <utility>

namespace ioct {

namespace {

// syslog(3) priorities, as the journal reads them at the start of a line (sd-daemon(3)).
std::string_view journal_priority(Severity severity) noexcept {
  switch (severity) {
    case Severity::info:
      return "<6>";
    case Severity::warning:
      return "<4>";
    case Severity::error:
      return "<3>";
  }
  return "<6>";
}

void write_whole(int fd, std::string_view bytes) noexcept {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // nowhere left to say it
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

}  // namespace

bool stderr_is_journal() noexcept {
  // Read while a Log is made, at a process's start; nothing of ours sets the environment.
  const char* stream = std::getenv("JOURNAL_STREAM");  // NOLINT(concurrency-mt-unsafe)
  if (stream == nullptr) return false;
  unsigned long long device = 0;
  unsigned long long inode = 0;
  if (std::sscanf(stream, "%llu:%llu", &device, &inode) != 2) return false;
  struct stat st {};
  if (::fstat(STDERR_FILENO, &st) != 0) return false;
  return static_cast<unsigned long long>(st.st_dev) == device &&
         static_cast<unsigned long long>(st.st_ino) == inode;
}

Log::Log(std::string program) : program_(std::move(program)), journal_(stderr_is_journal()) {}

Log::Log(std::string program, std::ostream& out) : program_(std::move(program)), out_(&out) {}

std::string Log::format(Severity severity, std::string_view text) const {
  std::string line = program_;
  line += ": ";
  if (severity == Severity::warning) line += "warning: ";
  if (severity == Severity::error) line += "error: ";
  line += text;
  return line;
}

void Log::emit(Severity severity, std::string_view line) const {
  std::string whole = journal_ ? std::string(journal_priority(severity)) : std::string();
  whole += line;
  whole += '\n';
  const std::lock_guard lock(mutex_);
  if (out_ != nullptr) {
    *out_ << whole << std::flush;
  } else {
    write_whole(STDERR_FILENO, whole);
  }
}

}  // namespace ioct
