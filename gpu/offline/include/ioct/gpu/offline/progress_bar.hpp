// A progress bar for long offline jobs, on stderr and only when stderr is a terminal, so logs and
// pipes get no control characters:
//   ioct-process [##########----------]  50%  64/128 B-scans
// redrawn in place (carriage return) at most every 100 ms and once at the end.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace ioct::gpu::offline {

class ProgressBar {
 public:
  // Draws on `stream` only when `enabled`; see stderr_is_terminal().
  ProgressBar(std::FILE* stream, std::string label, std::string unit, std::uint64_t total,
              bool enabled);
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  // Ends the line if a bar was drawn, so a message after an error starts on its own line.
  ~ProgressBar();

  static bool stderr_is_terminal() noexcept;

  void update(std::uint64_t done);
  // Draws the final state and ends the line.
  void finish();

 private:
  void draw();

  std::FILE* stream_;
  std::string label_;
  std::string unit_;
  std::uint64_t total_;
  std::uint64_t done_ = 0;
  bool enabled_;
  bool drawn_ = false;
  bool finished_ = false;
  std::chrono::steady_clock::time_point last_draw_{};
};

}  // namespace ioct::gpu::offline
