// The lock counter must really count: every planted lock and wait shows up, on the thread that
// made it only. A counter that missed them (its definitions not the ones the program binds to)
// would make every "0 locks" test pass. Skipped, saying why, where the build cannot count.
#include "ioct/test_support/lock_counter.hpp"

#include <gtest/gtest.h>
#include <linux/futex.h>
#include <semaphore.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <shared_mutex>
#include <thread>

namespace ioct::test_support {
namespace {

using namespace std::chrono_literals;

template <typename Plant>
std::uint64_t locks_taken_by(Plant plant) {
  const LockCounter counter;
  plant();
  return counter.acquisitions();
}

// A std::mutex locked once, a std::shared_mutex locked exclusively and shared, and a
// condition_variable waited on for 1 ms: 1 + 2 + 2 (the wait's own lock and the wait).
constexpr std::uint64_t kPlantedLocks = 5;

std::uint64_t plant_mutex_shared_mutex_and_condition_wait() {
  std::uint64_t total = 0;
  std::mutex mutex;
  const std::uint64_t by_mutex = locks_taken_by([&] {
    mutex.lock();
    mutex.unlock();
  });
  EXPECT_EQ(by_mutex, 1u) << "std::mutex, counted by " << lock_counting_method();
  total += by_mutex;

  std::shared_mutex shared;
  const std::uint64_t by_shared_mutex = locks_taken_by([&] {
    shared.lock();
    shared.unlock();
    shared.lock_shared();
    shared.unlock_shared();
  });
  EXPECT_EQ(by_shared_mutex, 2u) << "std::shared_mutex, counted by " << lock_counting_method();
  total += by_shared_mutex;

  std::condition_variable condition;
  const std::uint64_t by_condition_wait = locks_taken_by([&] {
    std::unique_lock lock(mutex);
    condition.wait_for(lock, 1ms);
  });
  EXPECT_EQ(by_condition_wait, 2u)
      << "condition_variable::wait_for, counted by " << lock_counting_method();
  total += by_condition_wait;
  return total;
}

TEST(LockCounter, CountsAPlantedMutexAndConditionWait) {
  if (!lock_counting_available()) GTEST_SKIP() << lock_counting_method();
  EXPECT_EQ(plant_mutex_shared_mutex_and_condition_wait(), kPlantedLocks);
}

TEST(LockCounter, CountsOnTheLockingThreadOnly) {
  if (!lock_counting_available()) GTEST_SKIP() << lock_counting_method();
  std::atomic<bool> go{false};
  std::uint64_t taken_by_other_thread = 0;
  std::thread other([&] {
    while (!go.load()) std::this_thread::yield();
    taken_by_other_thread = plant_mutex_shared_mutex_and_condition_wait();
  });
  // Counted after the thread exists; join() is not a lock.
  const LockCounter counter;
  go.store(true);
  other.join();
  EXPECT_EQ(taken_by_other_thread, kPlantedLocks);
  EXPECT_EQ(counter.acquisitions(), 0u);
}

TEST(LockCounter, CountsTheOtherWaits) {
  if (!lock_counting_available()) GTEST_SKIP() << lock_counting_method();
  // A condition_variable's untimed wait is in libstdc++ itself, not inlined here: it shows that
  // the library's calls come here too.
  std::mutex mutex;
  std::condition_variable condition;
  bool woken = false;
  std::thread waker([&] {
    std::this_thread::sleep_for(5ms);
    {
      const std::lock_guard lock(mutex);
      woken = true;
    }
    condition.notify_one();
  });
  EXPECT_GE(locks_taken_by([&] {
              std::unique_lock lock(mutex);
              while (!woken) condition.wait(lock);
            }),
            2u)
      << "condition_variable::wait";
  waker.join();

  sem_t semaphore;
  ASSERT_EQ(::sem_init(&semaphore, 0, 1), 0);
  EXPECT_EQ(locks_taken_by([&] { ::sem_wait(&semaphore); }), 1u) << "sem_wait";
  ::sem_destroy(&semaphore);

  // FUTEX_WAIT on a word that no longer holds the expected value returns at once (EAGAIN): still
  // a call that could have slept, and counted.
  std::uint32_t word = 0;
  EXPECT_EQ(locks_taken_by(
                [&] { ::syscall(SYS_futex, &word, FUTEX_WAIT_PRIVATE, 1, nullptr, nullptr, 0); }),
            1u)
      << "syscall(SYS_futex, FUTEX_WAIT)";
  std::atomic<std::uint32_t> flag{0};
  std::thread notifier([&] {
    std::this_thread::sleep_for(20ms);
    flag.store(1);
    flag.notify_one();
  });
  EXPECT_GE(locks_taken_by([&] {
              while (flag.load() == 0) flag.wait(0);
            }),
            1u)
      << "std::atomic::wait (a futex wait once it stops spinning)";
  notifier.join();
}

TEST(LockCounter, CountsNoTryLockWakeOrOtherSystemCall) {
  if (!lock_counting_available()) GTEST_SKIP() << lock_counting_method();
  std::mutex mutex;
  std::condition_variable condition;
  std::uint32_t word = 0;
  EXPECT_EQ(locks_taken_by([&] {
              if (mutex.try_lock()) mutex.unlock();
              condition.notify_all();
              ::syscall(SYS_futex, &word, FUTEX_WAKE_PRIVATE, 1, nullptr, nullptr, 0);
              ::syscall(SYS_getpid);
            }),
            0u);
}

TEST(LockCounter, SaysWhetherThisBuildCounts) {
  EXPECT_EQ(locks_are_counted_or_say_why(), lock_counting_available());
  EXPECT_FALSE(lock_counting_method().empty());
}

TEST(LockCounter, LeavesOutTheLocksOfAScopeThatSaysSo) {
  if (!lock_counting_available()) GTEST_SKIP() << lock_counting_method();
  std::mutex mutex;
  EXPECT_EQ(locks_taken_by([&] {
              const LocksNotCounted fake_hardware;
              {
                const LocksNotCounted nested;
                const std::lock_guard lock(mutex);
              }
              const std::lock_guard lock(mutex);
            }),
            0u);
  EXPECT_EQ(locks_taken_by([&] { const std::lock_guard lock(mutex); }), 1u)
      << "counted again once the scope ended";
}

}  // namespace
}  // namespace ioct::test_support
