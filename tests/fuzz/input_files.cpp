#include "input_files.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <system_error>

namespace ioct::fuzz {
namespace {

// A harness that cannot write its input is broken, not the parser: stop loudly.
[[noreturn]] void harness_failure(const std::string& what) {
  throw std::system_error(errno, std::generic_category(), "fuzz harness: " + what);
}

void write_all(int fd, const std::uint8_t* data, std::size_t size) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::pwrite(fd, data + done, size - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) harness_failure("write");
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace

MemoryFile::MemoryFile(const char* name) {
  fd_ = ::memfd_create(name, MFD_CLOEXEC);
  if (fd_ < 0) harness_failure("memfd_create");
  path_ = "/proc/self/fd/" + std::to_string(fd_);
}

MemoryFile::~MemoryFile() {
  ::close(fd_);
}

void MemoryFile::assign(const std::uint8_t* data, std::size_t size) {
  if (::ftruncate(fd_, 0) != 0) harness_failure("ftruncate");
  write_all(fd_, data, size);
}

ScratchDirectory::ScratchDirectory() {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/ioct-fuzz.XXXXXX";
  if (::mkdtemp(pattern.data()) == nullptr) harness_failure("mkdtemp " + pattern);
  path_ = pattern;
}

ScratchDirectory::~ScratchDirectory() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

std::filesystem::path ScratchDirectory::write(const std::string& name, const std::uint8_t* data,
                                              std::size_t size) {
  const std::filesystem::path file = path_ / name;
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) harness_failure("open " + file.string());
  write_all(fd, data, size);
  ::close(fd);
  return file;
}

}  // namespace ioct::fuzz
