// Files for the parsers that take a path: the fuzzer's bytes are written to a file the parser
// opens as it would any input. One memfd per process (no disk, nothing left behind), named by
// /proc/self/fd/N, which the readers see as a regular file of exactly those bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace ioct::fuzz {

class MemoryFile {
 public:
  explicit MemoryFile(const char* name);
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  ~MemoryFile();

  // Replaces the file's contents by `data`.
  void assign(const std::uint8_t* data, std::size_t size);
  const std::filesystem::path& path() const noexcept { return path_; }

 private:
  int fd_ = -1;
  std::filesystem::path path_;
};

// A private directory under $TMPDIR (or /tmp), removed with its files at exit: for a reader that
// finds its data files beside the one it was given (a recording's STEM.json and STEM.raw).
class ScratchDirectory {
 public:
  ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  ~ScratchDirectory();

  // Writes `name` in the directory with exactly these bytes and returns its path.
  std::filesystem::path write(const std::string& name, const std::uint8_t* data, std::size_t size);
  const std::filesystem::path& path() const noexcept { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace ioct::fuzz
