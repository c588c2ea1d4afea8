// How much later than its real-time bound a test lets a thread act when it runs without
// real-time scheduling, said in one place for the in-process rigs and the process tests.
#pragma once

#include <cstdint>

#include "ioct/test_support/sanitizer_build.hpp"

namespace ioct::test_support {

// What a timing bound allows on top of its real-time figure when the threads run without
// real-time scheduling: a loaded CI machine delays a thread by tens of ms, a sanitizer's build
// starved on two cores by hundreds. A thread that never acts still fails.
inline constexpr std::uint64_t kNotRealtimeAllowanceNs = kSanitized ? 1'000'000'000 : 100'000'000;

}  // namespace ioct::test_support
