#include "ioct/test_support/scoped_shm_name.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <system_error>

namespace ioct::test_support {

ScopedShmName::ScopedShmName(std::string_view tag) {
  static std::atomic<unsigned> counter{0};
  name_ = "ioct-test-" + std::string(tag) + "-" + std::to_string(::getpid()) + "-" +
          std::to_string(counter.fetch_add(1));
  remove_all();
}

ScopedShmName::~ScopedShmName() {
  remove_all();
}

std::size_t ScopedShmName::remove_all() const noexcept {
  std::size_t removed = 0;
  try {
    if (::shm_unlink(name_.c_str()) == 0) ++removed;
    for (const std::string& derived : shm_objects_with_prefix(name_ + ".")) {
      if (::shm_unlink(derived.c_str()) == 0) ++removed;
    }
  } catch (...) {
    // Listing /dev/shm failed: what could be removed by name was removed.
  }
  return removed;
}

std::vector<std::string> shm_objects_with_prefix(const std::string& prefix) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/dev/shm", ec)) {
    std::string name = entry.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) == 0) names.push_back(std::move(name));
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace ioct::test_support
