// Live words in shared memory: plain std::uint64_t fields accessed only through std::atomic_ref.
//
// Keeping the mapped structs free of std::atomic members keeps them trivially copyable with a
// layout that is exactly what the struct says, as a cross-process contract must be. A 64-bit
// lock-free atomic is address-free, so it works between processes that map the same pages.
#pragma once

#include <atomic>
#include <cstdint>

namespace ioct::shm {

static_assert(std::atomic_ref<std::uint64_t>::is_always_lock_free,
              "the ring needs lock-free 64-bit atomics: no lock may live in shared memory");
static_assert(std::atomic_ref<std::uint64_t>::required_alignment <= alignof(std::uint64_t));
static_assert(std::atomic_ref<std::uint32_t>::is_always_lock_free);

// Readers map the ring read-only, so their words are const. A lock-free 64-bit load is a plain
// load on every target we build for (never a read-modify-write), so loading through a
// const_cast reference never writes to the read-only page.
inline std::uint64_t load_word(const std::uint64_t& word, std::memory_order order) noexcept {
  return std::atomic_ref<std::uint64_t>(const_cast<std::uint64_t&>(word)).load(order);
}

// The 32-bit words (a futex's) the same way.
inline std::uint32_t load_word(const std::uint32_t& word, std::memory_order order) noexcept {
  return std::atomic_ref<std::uint32_t>(const_cast<std::uint32_t&>(word)).load(order);
}

inline void store_word(std::uint64_t& word, std::uint64_t value, std::memory_order order) noexcept {
  std::atomic_ref<std::uint64_t>(word).store(value, order);
}

inline std::uint64_t add_word(std::uint64_t& word, std::uint64_t delta,
                              std::memory_order order) noexcept {
  return std::atomic_ref<std::uint64_t>(word).fetch_add(delta, order);
}

}  // namespace ioct::shm
