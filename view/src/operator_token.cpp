#include "operator_token.hpp"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "ioct/common/config_error.hpp"

namespace ioct::view {
namespace {

[[noreturn]] void refuse(const std::filesystem::path& file, const std::string& why) {
  throw ConfigError("view.token_file", "'" + file.string() + "'", why);
}

std::string read_small_file(const std::filesystem::path& file) {
  // O_NONBLOCK: a FIFO put in the token's place must not hang the start.
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOFOLLOW);
  if (fd < 0) refuse(file, std::string("cannot be opened: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    refuse(file, "must be a regular file");
  }
  if ((st.st_mode & 077) != 0) {
    ::close(fd);
    refuse(file, "must be readable by its owner only (chmod 600)");
  }
  char buffer[512];
  const ssize_t n = ::read(fd, buffer, sizeof buffer);
  ::close(fd);
  if (n < 0) refuse(file, std::string("cannot be read: ") + std::strerror(errno));
  return std::string(buffer, static_cast<std::size_t>(n));
}

}  // namespace

OperatorToken OperatorToken::read(const std::filesystem::path& file) {
  std::string text = read_small_file(file);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) {
    text.pop_back();
  }
  if (text.size() < 16 || text.size() > 256) {
    refuse(file, "must hold one token of 16 to 256 characters");
  }
  for (const char c : text) {
    if (c <= 0x20 || c >= 0x7f) refuse(file, "the token must be printable ASCII without spaces");
  }
  return OperatorToken(std::move(text));
}

OperatorToken OperatorToken::read_or_make(const std::filesystem::path& file) {
  std::error_code ec;
  if (std::filesystem::exists(std::filesystem::symlink_status(file, ec))) return read(file);
  unsigned char bytes[16];
  if (::getrandom(bytes, sizeof bytes, 0) != static_cast<ssize_t>(sizeof bytes)) {
    refuse(file, "no random bytes to make a token from");
  }
  static const char* hex = "0123456789abcdef";
  std::string token;
  for (const unsigned char b : bytes) {
    token.push_back(hex[b >> 4]);
    token.push_back(hex[b & 15]);
  }
  std::filesystem::create_directories(file.parent_path(), ec);
  // Made 0600 from the first byte: the token is never readable by others, not even briefly.
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) refuse(file, std::string("cannot be created: ") + std::strerror(errno));
  token.push_back('\n');
  const bool written =
      ::write(fd, token.data(), token.size()) == static_cast<ssize_t>(token.size());
  ::close(fd);
  if (!written) refuse(file, "cannot be written");
  return read(file);
}

bool OperatorToken::matches(std::string_view presented) const noexcept {
  // Constant time in the token's content: every byte is compared whatever differs first.
  unsigned char diff = presented.size() == token_.size() ? 0 : 1;
  for (std::size_t i = 0; i < token_.size(); ++i) {
    const char p = i < presented.size() ? presented[i] : '\0';
    diff |= static_cast<unsigned char>(p ^ token_[i]);
  }
  return diff == 0;
}

}  // namespace ioct::view
