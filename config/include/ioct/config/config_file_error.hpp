// Where a configuration key was found in a file, and the error that names that place.
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

#include "ioct/common/error.hpp"

namespace ioct::config {

// Where a key came from in a file: "scan.extent_x" -> line 12, column 1.
struct SourcePosition {
  std::uint32_t line = 0;
  std::uint32_t column = 0;
};
using KeyPositions = std::map<std::string, SourcePosition>;

// A configuration file's error: "<file>:<line>:<column>: <ConfigError text>". Category config.
class ConfigFileError : public std::runtime_error, public Error {
 public:
  ConfigFileError(const std::string& file, SourcePosition position, const std::string& message);
  // An error of the file as a whole (it could not be read): `message` as it is.
  ConfigFileError(const std::string& file, const std::string& message);
  const std::string& file() const noexcept { return file_; }
  SourcePosition position() const noexcept { return position_; }

 private:
  std::string file_;
  SourcePosition position_;
};

// The most bytes a configuration file may have.
inline constexpr std::uint64_t kMaxConfigBytes = 1 << 20;

}  // namespace ioct::config
