// A pause between two looks of a thread that waits awake (polling a flag or a ring): tells the
// core it is a spin, so it draws less power and a sibling hyperthread gets the core meanwhile.
#pragma once

namespace ioct {

inline void spin_pause() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

}  // namespace ioct
