#include "ioct/gpu/offline/progress_bar.hpp"

#include <unistd.h>

#include <algorithm>

namespace ioct::gpu::offline {

ProgressBar::ProgressBar(std::FILE* stream, std::string label, std::string unit,
                         std::uint64_t total, bool enabled)
    : stream_(stream),
      label_(std::move(label)),
      unit_(std::move(unit)),
      total_(total),
      enabled_(enabled && stream != nullptr) {}

ProgressBar::~ProgressBar() {
  if (drawn_ && !finished_) std::fputc('\n', stream_);
}

bool ProgressBar::stderr_is_terminal() noexcept {
  return ::isatty(STDERR_FILENO) == 1;
}

void ProgressBar::update(std::uint64_t done) {
  done_ = std::min(done, total_);
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && now - last_draw_ < std::chrono::milliseconds(100) && done_ < total_) return;
  last_draw_ = now;
  draw();
}

void ProgressBar::finish() {
  if (finished_) return;
  done_ = total_;
  if (enabled_) {
    draw();
    std::fputc('\n', stream_);
    std::fflush(stream_);
  }
  finished_ = true;
}

void ProgressBar::draw() {
  constexpr int kWidth = 30;
  const double fraction = total_ == 0 ? 1.0 : double(done_) / double(total_);
  const int filled = static_cast<int>(fraction * kWidth);
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(kWidth, '-');
  std::fprintf(stream_, "\r%s [%s] %3d%%  %llu/%llu %s", label_.c_str(), bar.c_str(),
               static_cast<int>(fraction * 100), static_cast<unsigned long long>(done_),
               static_cast<unsigned long long>(total_), unit_.c_str());
  std::fflush(stream_);
  drawn_ = true;
}

}  // namespace ioct::gpu::offline
