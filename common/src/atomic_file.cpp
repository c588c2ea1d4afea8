#include "ioct/common/atomic_file.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

namespace ioct {
namespace {

std::runtime_error file_error(const std::filesystem::path& path, const char* what, int error) {
  return std::runtime_error("cannot " + std::string(what) + " '" + path.string() +
                            "': " + std::strerror(error));
}

}  // namespace

AtomicFile::AtomicFile(std::filesystem::path target) : target_(std::move(target)) {
  static std::atomic<unsigned> counter{0};
  const std::string name = "." + target_.filename().string() + ".tmp-" +
                           std::to_string(::getpid()) + "-" + std::to_string(counter++);
  temporary_ = target_.parent_path() / name;
  stream_ = std::fopen(temporary_.c_str(), "wbx");
  if (stream_ == nullptr) throw file_error(temporary_, "create", errno);
}

AtomicFile::~AtomicFile() {
  if (stream_ != nullptr) std::fclose(stream_);
  if (!committed_) ::unlink(temporary_.c_str());
}

void AtomicFile::commit() {
  const bool written = std::fflush(stream_) == 0 && std::ferror(stream_) == 0;
  int error = errno;
  const bool closed = std::fclose(stream_) == 0;
  if (!closed && written) error = errno;
  stream_ = nullptr;
  if (!written || !closed) throw file_error(target_, "write", error == 0 ? EIO : error);
  if (std::rename(temporary_.c_str(), target_.c_str()) != 0) {
    throw file_error(target_, "rename a finished file onto", errno);
  }
  committed_ = true;
}

void write_text_file_atomically(const std::filesystem::path& target, std::string_view text) {
  AtomicFile file(target);
  if (std::fwrite(text.data(), 1, text.size(), file.stream()) != text.size()) {
    throw file_error(target, "write", errno);
  }
  file.commit();
}

}  // namespace ioct
