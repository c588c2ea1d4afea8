#include "umockdev_reexec.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace ioct::hal::usb::test {
namespace {

void prepend(const char* variable, const std::string& value, const char* separator) {
  const char* old = std::getenv(variable);
  const std::string combined = old != nullptr && *old != '\0' ? value + separator + old : value;
  setenv(variable, combined.c_str(), 1);
}

}  // namespace

void reexec_under_umockdev(char** argv) {
  if (std::getenv("IOCT_UMOCKDEV_REEXEC") != nullptr) return;
  setenv("IOCT_UMOCKDEV_REEXEC", "1", 1);
  prepend("LD_PRELOAD", "libumockdev-preload.so.0", ":");
  // AddressSanitizer insists on being first in the library list; umockdev must be first too.
  prepend("ASAN_OPTIONS", "verify_asan_link_order=0", ":");
#ifdef IOCT_UMOCKDEV_TSAN_SUPPRESSIONS
  // umockdev, GLib and libudev are not instrumented; see the suppressions file for what it hides.
  prepend("TSAN_OPTIONS", "suppressions=" IOCT_UMOCKDEV_TSAN_SUPPRESSIONS, " ");
#endif
  execv("/proc/self/exe", argv);
  std::perror("re-executing under libumockdev-preload failed; umockdev tests will skip");
}

}  // namespace ioct::hal::usb::test
