// Shared-memory names for tests: unique to the process and the call, so runs in parallel never
// meet, and removed afterwards together with every object derived from them (a ring's reader
// status objects, those of killed readers included).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace ioct::test_support {

class ScopedShmName {
 public:
  // "ioct-test-<tag>-<pid>-<n>".
  explicit ScopedShmName(std::string_view tag);
  ~ScopedShmName();
  ScopedShmName(const ScopedShmName&) = delete;
  ScopedShmName& operator=(const ScopedShmName&) = delete;

  const std::string& str() const noexcept { return name_; }
  // The object and every "<name>.*" object; returns how many were removed.
  std::size_t remove_all() const noexcept;

 private:
  std::string name_;
};

// Names of the shared-memory objects (in /dev/shm) that start with `prefix`, sorted.
std::vector<std::string> shm_objects_with_prefix(const std::string& prefix);

}  // namespace ioct::test_support
