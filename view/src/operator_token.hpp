// The operators' token: who may change the render and the scan. Read from a file only its owner
// can read (0600 or stricter), or made at random on first start and kept in such a file, so a
// restart does not log the assistant out. Compared in constant time.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace ioct::view {

class OperatorToken {
 public:
  // Reads `file`; throws ConfigError ("view.token_file") when it is missing, readable by others,
  // not a regular file, or holds no token of 16 to 256 printable characters.
  static OperatorToken read(const std::filesystem::path& file);
  // Reads `file` if it exists, else makes a random token (32 hex digits from getrandom) and
  // writes it there with mode 0600.
  static OperatorToken read_or_make(const std::filesystem::path& file);

  bool matches(std::string_view presented) const noexcept;
  const std::string& value() const noexcept { return token_; }

 private:
  explicit OperatorToken(std::string token) : token_(std::move(token)) {}
  std::string token_;
};

}  // namespace ioct::view
