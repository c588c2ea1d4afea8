// A program's log: one line per call, "program: text", "program: warning: text" or
// "program: error: text", written whole (one write, so lines from several threads never mix). To
// standard error by default: under systemd that is the journal, and each line then starts with its
// syslog priority (<6>, <4>, <3>), so `journalctl -p warning` finds the warnings. Safe from any
// thread except the real-time ones, which hand their lines to a housekeeping thread instead.
#pragma once

#include <iosfwd>
#include <mutex>
#include <string>
#include <string_view>

namespace ioct {

enum class Severity { info, warning, error };

class Log {
 public:
  // To standard error.
  explicit Log(std::string program);
  // To `out` (a stream a test reads, or a tool's standard output), which must outlive the log.
  Log(std::string program, std::ostream& out);
  Log(const Log&) = delete;
  Log& operator=(const Log&) = delete;
  Log(Log&&) = delete;
  Log& operator=(Log&&) = delete;
  ~Log() = default;

  void info(std::string_view text) const { write(Severity::info, text); }
  void warning(std::string_view text) const { write(Severity::warning, text); }
  void error(std::string_view text) const { write(Severity::error, text); }
  void write(Severity severity, std::string_view text) const {
    emit(severity, format(severity, text));
  }
  // Writes a line already formatted (it names the program), e.g. describe_failure()'s.
  void emit(Severity severity, std::string_view line) const;

  // The line as written (without the journal's priority and the newline).
  [[nodiscard]] std::string format(Severity severity, std::string_view text) const;
  [[nodiscard]] const std::string& program() const noexcept { return program_; }

 private:
  std::string program_;
  std::ostream* out_ = nullptr;  // null: standard error
  bool journal_ = false;         // standard error is the journal: prefix each line's priority
  mutable std::mutex mutex_;
};

// True when standard error is the systemd journal's stream (JOURNAL_STREAM names its device and
// inode, systemd.exec(5)), so a line may start with its priority.
[[nodiscard]] bool stderr_is_journal() noexcept;

}  // namespace ioct
