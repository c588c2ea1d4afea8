// Counts heap allocations per thread; see allocation_counter.hpp for how each build counts.
#include "ioct/test_support/allocation_counter.hpp"

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <new>

#include "ioct/test_support/sanitizer_build.hpp"

namespace {

// initial-exec: reading the counter from inside malloc must not itself allocate (the general
// dynamic TLS model may call __tls_get_addr, which can allocate).
__attribute__((tls_model("initial-exec"))) thread_local std::uint64_t t_allocations = 0;
__attribute__((tls_model("initial-exec"))) thread_local std::uint64_t t_deallocations = 0;

inline void count_allocation() noexcept {
  ++t_allocations;
}
inline void count_deallocation(const volatile void* block) noexcept {
  if (block != nullptr) ++t_deallocations;
}

}  // namespace

namespace ioct::test_support {

std::uint64_t thread_allocations() noexcept {
  return t_allocations;
}
std::uint64_t thread_deallocations() noexcept {
  return t_deallocations;
}

}  // namespace ioct::test_support

#if IOCT_SANITIZED  // the sanitizer owns malloc

// The sanitizer replaces malloc and operator new itself; replacing them again would bypass its
// checks. It calls these hooks on the allocating thread instead.
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*,
                                                                             std::size_t),
                                                         void (*free_hook)(const volatile void*));

namespace {

void on_sanitizer_malloc(const volatile void*, std::size_t) {
  count_allocation();
}
void on_sanitizer_free(const volatile void* block) {
  count_deallocation(block);
}

// Before main: a counter that silently counted nothing would make every "0 allocations" pass.
__attribute__((constructor)) void install_allocation_hooks() {
  if (__sanitizer_install_malloc_and_free_hooks(&on_sanitizer_malloc, &on_sanitizer_free) == 0) {
    std::fputs("allocation_counter: the sanitizer refused the malloc hooks\n", stderr);
    std::abort();
  }
}

}  // namespace

namespace ioct::test_support {
std::string_view allocation_counting_method() noexcept {
  return "sanitizer hooks";
}
}  // namespace ioct::test_support

#else

// glibc's own allocator entry points: the replacements below count and forward to them.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* block, std::size_t size);
void __libc_free(void* block);
void* __libc_memalign(std::size_t alignment, std::size_t size);
}

namespace ioct::test_support {
std::string_view allocation_counting_method() noexcept {
  return "malloc replacement";
}
}  // namespace ioct::test_support

extern "C" {

void* malloc(std::size_t size) noexcept {
  count_allocation();
  return __libc_malloc(size);
}

void* calloc(std::size_t count, std::size_t size) noexcept {
  count_allocation();
  return __libc_calloc(count, size);
}

void* realloc(void* block, std::size_t size) noexcept {
  if (block != nullptr && size == 0) {
    count_deallocation(block);  // glibc frees the block and returns null
  } else {
    count_allocation();  // a new block, or possibly a moved one
  }
  return __libc_realloc(block, size);
}

void free(void* block) noexcept {
  count_deallocation(block);
  __libc_free(block);
}

void* memalign(std::size_t alignment, std::size_t size) noexcept {
  count_allocation();
  return __libc_memalign(alignment, size);
}

void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  count_allocation();
  return __libc_memalign(alignment, size);
}

int posix_memalign(void** block, std::size_t alignment, std::size_t size) noexcept {
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  count_allocation();
  void* const p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *block = p;
  return 0;
}

}  // extern "C"

namespace {

void* allocate_or_throw(std::size_t size, std::size_t alignment) {
  if (size == 0) size = 1;
  count_allocation();
  for (;;) {
    void* const p = alignment <= alignof(std::max_align_t) ? __libc_malloc(size)
                                                           : __libc_memalign(alignment, size);
    if (p != nullptr) return p;
    const std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

void* allocate_or_null(std::size_t size, std::size_t alignment) noexcept {
  try {
    return allocate_or_throw(size, alignment);
  } catch (...) {
    return nullptr;
  }
}

void deallocate(void* block) noexcept {
  count_deallocation(block);
  __libc_free(block);
}

constexpr std::size_t kDefaultAlignment = alignof(std::max_align_t);

}  // namespace

void* operator new(std::size_t size) {
  return allocate_or_throw(size, kDefaultAlignment);
}
void* operator new[](std::size_t size) {
  return allocate_or_throw(size, kDefaultAlignment);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return allocate_or_null(size, kDefaultAlignment);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return allocate_or_null(size, kDefaultAlignment);
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return allocate_or_throw(size, static_cast<std::size_t>(alignment));
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return allocate_or_throw(size, static_cast<std::size_t>(alignment));
}
void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return allocate_or_null(size, static_cast<std::size_t>(alignment));
}
void* operator new[](std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  return allocate_or_null(size, static_cast<std::size_t>(alignment));
}

void operator delete(void* block) noexcept {
  deallocate(block);
}
void operator delete[](void* block) noexcept {
  deallocate(block);
}
void operator delete(void* block, std::size_t) noexcept {
  deallocate(block);
}
void operator delete[](void* block, std::size_t) noexcept {
  deallocate(block);
}
void operator delete(void* block, const std::nothrow_t&) noexcept {
  deallocate(block);
}
void operator delete[](void* block, const std::nothrow_t&) noexcept {
  deallocate(block);
}
void operator delete(void* block, std::align_val_t) noexcept {
  deallocate(block);
}
void operator delete[](void* block, std::align_val_t) noexcept {
  deallocate(block);
}
void operator delete(void* block, std::size_t, std::align_val_t) noexcept {
  deallocate(block);
}
void operator delete[](void* block, std::size_t, std::align_val_t) noexcept {
  deallocate(block);
}
void operator delete(void* block, std::align_val_t, const std::nothrow_t&) noexcept {
  deallocate(block);
}
void operator delete[](void* block, std::align_val_t, const std::nothrow_t&) noexcept {
  deallocate(block);
}

#endif
