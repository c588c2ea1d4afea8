// The error every offline reader throws for a file it will not use: the message names the file
// and what is wrong with it ("volume.nrrd: truncated: 1000 of 4096 data bytes"), so a person can
// tell a damaged file from a wrong option.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ioct/common/input_file.hpp"

namespace ioct::gpu::offline {

// Category data (ioct/common/error.hpp).
class InputFileError : public std::runtime_error, public Error {
 public:
  InputFileError(const std::filesystem::path& path, std::string_view problem)
      : std::runtime_error(path.string() + ": " + std::string(problem)),
        Error(ErrorCategory::data),
        path_(path) {}
  const std::filesystem::path& path() const noexcept { return path_; }

 private:
  std::filesystem::path path_;
};

// The size of `path`, which must be a regular file: a FIFO would hang the reader and /dev/zero
// would never end. Checked before the file is opened for reading. Throws InputFileError.
inline std::uint64_t checked_input_size(const std::filesystem::path& path) {
  try {
    return ioct::regular_file_size(path.string(), "input file");
  } catch (const ioct::InputFileError& e) {
    throw InputFileError(path, e.reason());
  }
}

}  // namespace ioct::gpu::offline
