#include "live_image_writer.hpp"

#include <exception>
#include <utility>

#include "ioct/gpu/render/png_rgba.hpp"

namespace ioct::gpu::live {

LiveImageWriter::LiveImageWriter(std::filesystem::path path)
    : path_(std::move(path)), thread_([this] { work(); }) {}

LiveImageWriter::~LiveImageWriter() {
  stop();
}

void LiveImageWriter::submit(const render::RgbaImage& image) {
  {
    std::lock_guard lock(mutex_);
    if (stop_) return;
    waiting_ = image;
  }
  wake_.notify_one();
}

void LiveImageWriter::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

LiveImageWriter::Counts LiveImageWriter::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

void LiveImageWriter::work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || waiting_.has_value(); });
    if (!waiting_) return;  // stopped with nothing left
    const render::RgbaImage image = std::move(*waiting_);
    waiting_.reset();
    lock.unlock();
    std::string problem;
    try {
      render::write_png(path_, image);
    } catch (const std::exception& e) {
      problem = e.what();
    }
    lock.lock();
    if (problem.empty()) {
      ++counts_.written;
    } else {
      ++counts_.failed;
      counts_.problem = std::move(problem);
    }
  }
}

}  // namespace ioct::gpu::live
