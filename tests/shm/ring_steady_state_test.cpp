// The publishing path in steady state -- claim, fill, publish -- allocates nothing, takes no page
// fault and takes no lock on the writer's thread, with a reader copying groups on another thread
// meanwhile. Counted with the allocation, page-fault and lock counters of tests/support, which
// are first shown to see a planted allocation, a planted fault and a planted lock in this very
// binary.
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <mutex>
#include <thread>

#include "ioct/shm/ring_reader.hpp"
#include "ioct/shm/ring_writer.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "ioct/test_support/lock_counter.hpp"
#include "ioct/test_support/page_fault_counter.hpp"
#include "ioct/test_support/scoped_shm_name.hpp"
#include "test_group.hpp"

namespace ioct::ring_test {
namespace {

using test_support::AllocationCounter;
using test_support::LockCounter;
using test_support::PageFaultCounter;
using test_support::ScopedShmName;

void escape(void* p) {
  asm volatile("" : : "r"(p) : "memory");
}

TEST(RingSteadyState, CountersCatchAPlantedAllocationAPlantedFaultAndAPlantedLock) {
  {
    const AllocationCounter counter;
    auto* planted = new std::uint64_t[8];
    escape(planted);
    delete[] planted;
    EXPECT_EQ(counter.allocations(), 1u) << test_support::allocation_counting_method();
  }
  {
    const std::size_t page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    void* p =
        ::mmap(nullptr, 16 * page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ASSERT_NE(p, MAP_FAILED);
    const PageFaultCounter counter;
    for (std::size_t i = 0; i < 16; ++i) static_cast<volatile char*>(p)[i * page] = 1;
    EXPECT_GE(counter.faults().total(), 16u);
    ::munmap(p, 16 * page);
  }
  if (test_support::locks_are_counted_or_say_why()) {
    std::mutex planted;
    const LockCounter counter;
    { const std::lock_guard lock(planted); }
    EXPECT_EQ(counter.acquisitions(), 1u) << test_support::lock_counting_method();
  }
}

// A group big enough to span many pages (1376 samples x 64 A-scans x 4 B-scans x 2 bytes =
// 688 KiB), so that a payload page the prefault missed would show.
shm::RingConfig multi_page_config(const std::string& name) {
  shm::RingConfig config;
  config.name = name;
  config.geometry.samples_per_ascan = 1376;
  config.geometry.ascans_per_bscan = 64;
  config.geometry.bscans_per_group = 4;
  config.geometry.bscans_per_volume = 128;
  config.slot_count = 4;
  return config;
}

TEST(RingSteadyState, PublishingAllocatesNothingTakesNoPageFaultAndNoLock) {
  const ScopedShmName name("steady");
  shm::RingWriter writer = shm::RingWriter::create(multi_page_config(name.str()));
  std::printf(
      "[ info     ] ring of %llu bytes, memory %s, allocations counted by %s, locks by %s\n",
      static_cast<unsigned long long>(writer.layout().total_bytes),
      writer.memory_locked() ? "locked" : "not locked (RLIMIT_MEMLOCK)",
      std::string(test_support::allocation_counting_method()).c_str(),
      std::string(test_support::lock_counting_method()).c_str());

  // A reader copying groups on another thread all along, as in production.
  std::atomic<bool> stop{false};
  shm::RingReader reader = shm::RingReader::attach(name.str());
  std::thread reading([&] {
    std::vector<std::byte> buffer(reader.layout().group_payload_bytes);
    shm::SlotHeader header{};
    while (!stop.load()) {
      if (reader.read_next(buffer, header) == shm::PollStatus::empty) std::this_thread::yield();
    }
  });

  // Start-up: one full lap and one more group, so every slot, the code, the stack and the vDSO
  // clock have been touched once.
  for (std::uint64_t i = 0; i < writer.layout().slot_count + 1; ++i) publish_test_group(writer);

  constexpr std::uint64_t kSteadyGroups = 400;  // 100 laps
  const AllocationCounter allocations;
  const PageFaultCounter faults;
  const LockCounter locks;
  for (std::uint64_t i = 0; i < kSteadyGroups; ++i) publish_test_group(writer);
  const std::uint64_t allocated = allocations.allocations();
  const test_support::PageFaults faulted = faults.faults();
  const std::uint64_t locked = locks.acquisitions();

  stop.store(true);
  reading.join();
  EXPECT_EQ(allocated, 0u) << "heap allocations on the writer thread in steady state";
  EXPECT_EQ(faulted.total(), 0u) << "page faults on the writer thread in steady state: "
                                 << faulted.minor << " minor, " << faulted.major << " major";
  if (test_support::locks_are_counted_or_say_why()) {
    EXPECT_EQ(locked, 0u) << "locks taken on the writer thread in steady state, counted by "
                          << test_support::lock_counting_method();
  }
  EXPECT_GT(reader.counters().consumed, 0u) << "the reader ran alongside";
}

}  // namespace
}  // namespace ioct::ring_test
