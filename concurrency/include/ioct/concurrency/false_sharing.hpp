// How far apart two variables written by different threads must sit so that neither write drags
// the other's cache line between cores.
#pragma once

#include <cstddef>

namespace ioct {

// 128 bytes, as folly does: x86-64's adjacent-line prefetcher moves 64-byte lines in pairs, and
// the arm64 cores we build for have 64- or 128-byte lines. Not
// std::hardware_destructive_interference_size: GCC 12 warns that it changes with -mtune, and a
// layout must not.
inline constexpr std::size_t kFalseSharingRange = 128;

}  // namespace ioct
