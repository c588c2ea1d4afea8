// The page-fault counter must see first touches of fresh pages, on the touching thread only.
#include "ioct/test_support/page_fault_counter.hpp"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstddef>
#include <thread>

namespace ioct::test_support {
namespace {

constexpr std::size_t kPages = 64;  // 256 KiB: too small for a transparent huge page

class FreshPages {
 public:
  FreshPages() : page_(static_cast<std::size_t>(::sysconf(_SC_PAGESIZE))) {
    void* p =
        ::mmap(nullptr, kPages * page_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::runtime_error("mmap failed");
    base_ = static_cast<volatile char*>(p);
  }
  ~FreshPages() { ::munmap(const_cast<char*>(base_), kPages * page_); }
  void touch_all() {
    for (std::size_t i = 0; i < kPages; ++i) base_[i * page_] = static_cast<char>(i);
  }

 private:
  std::size_t page_;
  volatile char* base_ = nullptr;
};

TEST(PageFaultCounter, CountsFirstTouchOfFreshPages) {
  FreshPages pages;
  const PageFaultCounter counter;
  pages.touch_all();
  EXPECT_GE(counter.faults().total(), kPages);
}

TEST(PageFaultCounter, CountsNothingForPagesAlreadyTouched) {
  FreshPages pages;
  pages.touch_all();
  const PageFaultCounter counter;
  pages.touch_all();
  EXPECT_EQ(counter.faults().total(), 0u);
}

TEST(PageFaultCounter, CountsOnTheFaultingThreadOnly) {
  FreshPages pages;
  std::atomic<bool> go{false};
  std::uint64_t taken_by_other_thread = 0;
  std::thread other([&] {
    while (!go.load()) std::this_thread::yield();
    const PageFaultCounter counter;
    pages.touch_all();
    taken_by_other_thread = counter.faults().total();
  });
  const PageFaultCounter counter;
  go.store(true);
  other.join();
  EXPECT_GE(taken_by_other_thread, kPages);
  EXPECT_LT(counter.faults().total(), kPages);
}

}  // namespace
}  // namespace ioct::test_support
