// A file that appears under its name only once it is completely written: the bytes go to a
// hidden temporary file in the same directory, which commit() renames over the target. A reader
// (a browser reloading bscan.png, a script reading summary.json) never sees half a file, and a
// failed write leaves the previous file in place.
#pragma once

#include <cstdio>
#include <filesystem>
#include <string_view>

namespace ioct {

class AtomicFile {
 public:
  // Creates "<dir>/.<name>.tmp-<pid>-<n>". Throws std::runtime_error naming the path and the
  // reason (errno) when it cannot.
  explicit AtomicFile(std::filesystem::path target);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  // Removes the temporary file unless committed.
  ~AtomicFile();

  std::FILE* stream() const noexcept { return stream_; }
  const std::filesystem::path& target() const noexcept { return target_; }
  const std::filesystem::path& temporary() const noexcept { return temporary_; }

  // Flushes, closes and renames onto the target. Throws std::runtime_error naming the target and
  // the reason; the target is then unchanged.
  void commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temporary_;
  std::FILE* stream_ = nullptr;
  bool committed_ = false;
};

// Writes `text` to `target` through an AtomicFile.
void write_text_file_atomically(const std::filesystem::path& target, std::string_view text);

}  // namespace ioct
