// The allocation counter must really count: every planted allocation shows up, on the thread
// that made it only. A counter that missed them would make every "0 allocations" test pass.
#include "ioct/test_support/allocation_counter.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace ioct::test_support {
namespace {

// Keeps the compiler from proving an allocation unused and removing it.
void escape(void* p) {
  asm volatile("" : : "r"(p) : "memory");
}

struct alignas(128) OverAligned {
  char bytes[128];
};

#if defined(__SANITIZE_THREAD__)
// ThreadSanitizer runs the malloc hooks from its malloc, calloc, realloc and operator new only,
// not from posix_memalign, aligned_alloc or memalign: there this counter cannot see those.
constexpr std::uint64_t kAlignedAllocationsSeen = 0;
#else
constexpr std::uint64_t kAlignedAllocationsSeen = 1;
#endif

template <typename Plant>
std::uint64_t allocations_made_by(Plant plant) {
  const AllocationCounter counter;
  plant();
  return counter.allocations();
}

TEST(AllocationCounter, CountsEveryKindOfPlantedAllocation) {
  EXPECT_EQ(allocations_made_by([] {
              void* p = std::malloc(24);
              escape(p);
              std::free(p);
            }),
            1u)
      << "malloc";
  EXPECT_EQ(allocations_made_by([] {
              void* p = std::calloc(3, 8);
              escape(p);
              std::free(p);
            }),
            1u)
      << "calloc";
  EXPECT_EQ(allocations_made_by([] {
              void* p = std::realloc(nullptr, 40);
              escape(p);
              std::free(p);
            }),
            1u)
      << "realloc of null";
  EXPECT_EQ(allocations_made_by([] {
              void* p = nullptr;
              ASSERT_EQ(::posix_memalign(&p, 64, 256), 0);
              escape(p);
              std::free(p);
            }),
            kAlignedAllocationsSeen)
      << "posix_memalign";
  EXPECT_EQ(allocations_made_by([] {
              void* p = std::aligned_alloc(64, 256);
              escape(p);
              std::free(p);
            }),
            kAlignedAllocationsSeen)
      << "aligned_alloc";
  EXPECT_EQ(allocations_made_by([] {
              char* p = ::strdup("allocated by glibc itself");
              escape(p);
              std::free(p);
            }),
            1u)
      << "strdup";
  EXPECT_EQ(allocations_made_by([] {
              auto* p = new int(7);
              escape(p);
              delete p;
            }),
            1u)
      << "new";
  EXPECT_EQ(allocations_made_by([] {
              auto* p = new int[16];
              escape(p);
              delete[] p;
            }),
            1u)
      << "new[]";
  EXPECT_EQ(allocations_made_by([] {
              auto* p = new OverAligned;
              escape(p);
              delete p;
            }),
            1u)
      << "aligned new";
  EXPECT_EQ(allocations_made_by([] {
              std::vector<double> v;
              v.push_back(1.0);
              escape(v.data());
            }),
            1u)
      << "std::vector";
  EXPECT_EQ(allocations_made_by([] {
              std::string s(200, 'x');
              escape(s.data());
            }),
            1u)
      << "std::string";
  EXPECT_EQ(allocations_made_by([] {
              auto p = std::make_shared<int>(3);
              escape(p.get());
            }),
            1u)
      << "make_shared";
}

TEST(AllocationCounter, CountsFrees) {
  const AllocationCounter counter;
  for (int i = 0; i < 10; ++i) {
    void* p = std::malloc(64);
    escape(p);
    std::free(p);
  }
  EXPECT_EQ(counter.allocations(), 10u);
  EXPECT_EQ(counter.deallocations(), 10u);
}

TEST(AllocationCounter, CountsNothingForCodeThatDoesNotAllocate) {
  char buffer[256];
  const AllocationCounter counter;
  std::uint64_t sum = 0;
  for (int i = 0; i < 1000; ++i) {
    std::memset(buffer, i, sizeof buffer);
    escape(buffer);
    sum += static_cast<unsigned char>(buffer[i % sizeof buffer]);
  }
  EXPECT_EQ(counter.allocations(), 0u);
  EXPECT_GT(sum, 0u);
}

TEST(AllocationCounter, CountsOnTheAllocatingThreadOnly) {
  std::atomic<bool> go{false};
  std::uint64_t made_by_other_thread = 0;
  std::thread other([&] {
    while (!go.load()) std::this_thread::yield();
    const AllocationCounter counter;
    for (int i = 0; i < 1000; ++i) {
      auto* p = new long(i);
      escape(p);
      delete p;
    }
    made_by_other_thread = counter.allocations();
  });
  // Counted after the thread exists: creating it allocates on this thread.
  const AllocationCounter counter;
  go.store(true);
  other.join();
  EXPECT_EQ(made_by_other_thread, 1000u);
  EXPECT_EQ(counter.allocations(), 0u);
}

TEST(AllocationCounter, SaysHowThisBuildCounts) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  EXPECT_EQ(allocation_counting_method(), "sanitizer hooks");
#else
  EXPECT_EQ(allocation_counting_method(), "malloc replacement");
#endif
}

}  // namespace
}  // namespace ioct::test_support
