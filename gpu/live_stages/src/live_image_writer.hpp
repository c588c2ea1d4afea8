// The live view as a PNG file (render.png), rewritten on a thread of its own: zlib takes tens of
// milliseconds for a 1024x768 frame, which on the stages' thread would hold up the next group's
// frame for the viewers. Latest wins: an image handed over while another is being written
// replaces the one waiting, if any.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "ioct/gpu/render/rgba_image.hpp"

namespace ioct::gpu::live {

class LiveImageWriter {
 public:
  explicit LiveImageWriter(std::filesystem::path path);
  ~LiveImageWriter();  // stop()
  LiveImageWriter(const LiveImageWriter&) = delete;
  LiveImageWriter& operator=(const LiveImageWriter&) = delete;

  // A copy of `image` to be written (the caller's thread returns at once).
  void submit(const render::RgbaImage& image);
  // Writes what is waiting, then ends the thread.
  void stop();

  struct Counts {
    std::uint64_t written = 0, failed = 0;
    std::string problem;  // the last failure
  };
  Counts counts() const;

 private:
  void work();

  const std::filesystem::path path_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<render::RgbaImage> waiting_;
  bool stop_ = false;
  Counts counts_;
  std::thread thread_;
};

}  // namespace ioct::gpu::live
