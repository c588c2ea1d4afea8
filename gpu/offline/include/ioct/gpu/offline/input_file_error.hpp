// The error every offline reader throws for a file it will not use: the message names the file
// and what is wrong with it ("volume.nrrd: truncated: 1000 of 4096 data bytes"), so a person can
// tell a damaged file from a wrong option.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace ioct::gpu::offline {

class InputFileError : public std::runtime_error {
 public:
  InputFileError(const std::filesystem::path& path, std::string_view problem)
      : std::runtime_error(path.string() + ": " + std::string(problem)), path_(path) {}
  const std::filesystem::path& path() const noexcept { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace ioct::gpu::offline
