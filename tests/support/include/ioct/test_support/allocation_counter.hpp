// Per-thread heap-allocation counter, so a test can show that a region of code on one thread
// allocated nothing.
//
// Linking this (ioct_test_support, whose allocation_counter.cpp any use of these functions pulls
// in) makes every allocation in the program count against the thread that made it:
//  - normal builds replace malloc, calloc, realloc, free, aligned_alloc, posix_memalign, memalign
//    (forwarding to glibc's __libc_* functions) and the global operator new/delete;
//  - AddressSanitizer and ThreadSanitizer builds leave malloc to the sanitizer, which owns it,
//    and count through __sanitizer_install_malloc_and_free_hooks instead. ThreadSanitizer runs
//    those hooks for malloc, calloc, realloc and operator new but not for posix_memalign,
//    aligned_alloc or memalign, which it does not count there.
#pragma once

#include <cstdint>
#include <string_view>

namespace ioct::test_support {

// Heap allocations (malloc family, operator new) made so far by the calling thread.
std::uint64_t thread_allocations() noexcept;
// Heap blocks freed so far by the calling thread.
std::uint64_t thread_deallocations() noexcept;
// How this build counts: "malloc replacement" or "sanitizer hooks".
std::string_view allocation_counting_method() noexcept;

// Counts the calling thread's allocations from construction on. Use it on one thread only.
class AllocationCounter {
 public:
  AllocationCounter() noexcept
      : allocations_at_start_(thread_allocations()),
        deallocations_at_start_(thread_deallocations()) {}

  std::uint64_t allocations() const noexcept {
    return thread_allocations() - allocations_at_start_;
  }
  std::uint64_t deallocations() const noexcept {
    return thread_deallocations() - deallocations_at_start_;
  }

 private:
  std::uint64_t allocations_at_start_;
  std::uint64_t deallocations_at_start_;
};

}  // namespace ioct::test_support
