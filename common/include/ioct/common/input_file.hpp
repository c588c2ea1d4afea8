// Opening a file that came from outside (a configuration, a recording, an imported volume): it
// must be a regular file, so a FIFO cannot hang the command and /dev/zero cannot grow its memory
// without bound, and what is read of it is bounded by the file's real size and a stated maximum.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "ioct/common/error.hpp"

namespace ioct {

// "cannot read <what> '<path>': <reason>".
// Category data (error.hpp).
class InputFileError : public std::runtime_error, public Error {
 public:
  InputFileError(std::string_view what, const std::string& path, std::string reason);
  // Why, without the file: "it is a FIFO, not a regular file".
  const std::string& reason() const noexcept { return reason_; }

 private:
  std::string reason_;
};

// The size of the regular file at `path` (following links, as any reader would). Opens it
// non-blocking, so a FIFO is refused at once instead of waiting for a writer. Throws
// InputFileError naming `what` and the path for a missing file, a FIFO, a device or a directory.
std::uint64_t regular_file_size(const std::string& path, std::string_view what);

// The whole of a small regular file (a configuration, a JSON or header text): refused with
// InputFileError when it is not a regular file or is larger than `max_bytes`.
std::string read_small_file(const std::string& path, std::string_view what,
                            std::uint64_t max_bytes);

// `text` as a message may show it: printable ASCII only (other bytes as \xNN, quotes and
// backslashes escaped), at most `max_chars` of it followed by "..." and how long it was.
std::string quote_input(std::string_view text, std::size_t max_chars = 60);

// The product a * b, or false when it does not fit in 64 bits.
inline bool multiply_fits(std::uint64_t a, std::uint64_t b, std::uint64_t& product) {
  return !__builtin_mul_overflow(a, b, &product);
}

}  // namespace ioct
