// Whether this is a sanitizer's build, said in one place for the counters of tests/support and
// the timing bounds of the tests (not_realtime.hpp).
#pragma once

// AddressSanitizer or ThreadSanitizer (GCC defines the __SANITIZE_* macros, clang answers
// __has_feature). Such a build replaces malloc and operator new itself, and its threads run
// several times slower and starve each other on two cores. A macro, for the counters' #if.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define IOCT_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define IOCT_SANITIZED 1
#endif
#endif
#ifndef IOCT_SANITIZED
#define IOCT_SANITIZED 0
#endif

// ThreadSanitizer built by clang: its runtime is linked into the executable, where its
// interceptors of the pthread functions are weak definitions. The lock counter's definitions
// would replace them and forward straight to glibc, and ThreadSanitizer would see no lock at all
// (false races everywhere). GCC links its runtime as a shared library, after the executable:
// there the counter's definitions come first and forward to the interceptors.
#if defined(__clang__) && defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define IOCT_SANITIZER_INTERCEPTS_LOCKS_IN_EXECUTABLE 1
#endif
#endif

namespace ioct::test_support {

inline constexpr bool kSanitized = IOCT_SANITIZED != 0;

}  // namespace ioct::test_support
