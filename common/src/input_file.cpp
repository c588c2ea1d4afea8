#include "ioct/common/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

namespace ioct {
namespace {

[[noreturn]] void fail(std::string_view what, const std::string& path, const std::string& why) {
  throw InputFileError(what, path, why);
}

const char* kind_of(mode_t mode) {
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// An open descriptor of a regular file, closed on scope exit.
class RegularFile {
 public:
  RegularFile(const std::string& path, std::string_view what) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) fail(what, path, std::string("cannot open: ") + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd_, &st) != 0) {
      const int err = errno;
      ::close(fd_);
      fail(what, path, std::strerror(err));
    }
    if (!S_ISREG(st.st_mode)) {
      ::close(fd_);
      fail(what, path, std::string("it is ") + kind_of(st.st_mode) + ", not a regular file");
    }
    size_ = static_cast<std::uint64_t>(st.st_size);
  }
  RegularFile(const RegularFile&) = delete;
  RegularFile& operator=(const RegularFile&) = delete;
  ~RegularFile() { ::close(fd_); }
  int fd() const { return fd_; }
  std::uint64_t size() const { return size_; }

 private:
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

}  // namespace

InputFileError::InputFileError(std::string_view what, const std::string& path, std::string reason)
    : std::runtime_error("cannot read " + std::string(what) + " '" + quote_input(path, 200) +
                         "': " + reason),
      Error(ErrorCategory::data),
      reason_(std::move(reason)) {}

std::uint64_t regular_file_size(const std::string& path, std::string_view what) {
  return RegularFile(path, what).size();
}

std::string read_small_file(const std::string& path, std::string_view what,
                            std::uint64_t max_bytes) {
  const RegularFile file(path, what);
  if (file.size() > max_bytes) {
    fail(what, path,
         "it is " + std::to_string(file.size()) + " bytes, more than the " +
             std::to_string(max_bytes) + " such a file may have");
  }
  // Never more than max_bytes, even if the file grows while it is read.
  std::string text(static_cast<std::size_t>(file.size()), '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(file.fd(), text.data() + got, text.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail(what, path, std::strerror(errno));
    if (n == 0) break;
    got += static_cast<std::size_t>(n);
  }
  text.resize(got);
  return text;
}

std::string quote_input(std::string_view text, std::size_t max_chars) {
  std::string out;
  const std::size_t shown = std::min(text.size(), max_chars);
  for (std::size_t i = 0; i < shown; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '\\' || c == '"') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  if (shown < text.size()) out += "... (" + std::to_string(text.size()) + " bytes)";
  return out;
}

}  // namespace ioct
