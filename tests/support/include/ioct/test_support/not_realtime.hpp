// How much later than its real-time bound a test lets a thread act when it runs without
// real-time scheduling, said in one place for the in-process rigs and the process tests.
#pragma once

#include <cstdint>

namespace ioct::test_support {

// A sanitizer's build (ThreadSanitizer or AddressSanitizer; GCC defines __SANITIZE_*, clang
// answers __has_feature): its threads run several times slower and starve each other on two cores.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer) || __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

// What a timing bound allows on top of its real-time figure when the threads run without
// real-time scheduling: a loaded CI machine delays a thread by tens of ms, a sanitizer's build
// starved on two cores by hundreds. A thread that never acts still fails.
inline constexpr std::uint64_t kNotRealtimeAllowanceNs = kSanitized ? 1'000'000'000 : 100'000'000;

}  // namespace ioct::test_support
