// Per-thread lock counter, so a test can show that a region of code on one thread took no lock
// and waited on no other thread.
//
// Linking this (ioct_test_support, whose lock_counter.cpp the linker takes in for any use of these
// functions or of the pthread functions it defines) makes every call the program makes to one of
// these count against the calling thread:
//  - pthread_mutex_lock, _timedlock, _clocklock; pthread_rwlock_rdlock, _wrlock and their timed
//    and clock forms; pthread_spin_lock; pthread_cond_wait, _timedwait, _clockwait;
//    pthread_barrier_wait; sem_wait, sem_timedwait, sem_clockwait. std::mutex, std::shared_mutex
//    and std::condition_variable come down to these;
//  - syscall(SYS_futex, ...) with an operation that sleeps (FUTEX_WAIT, FUTEX_WAIT_BITSET,
//    FUTEX_LOCK_PI, FUTEX_LOCK_PI2, FUTEX_WAIT_REQUEUE_PI) and syscall(SYS_futex_waitv, ...):
//    our own futex waits, and std::atomic::wait, std::counting_semaphore and std::latch once they
//    stop spinning and sleep (a wait that ends while still spinning is not seen).
// Each call counts once, whether or not it had to wait: on a real-time path the call itself is the
// fault, and whether it waited depends on what other threads did that time.
// Not counted: try-locks (they never wait: the safety thread's status copy is one, by design);
// wakes (FUTEX_WAKE, notify, unlock: they do not block); locks glibc takes inside itself (stdio,
// the malloc arenas, the dynamic loader), which never go through these symbols; futex waits made
// with an inline system-call instruction rather than syscall(); and blocking calls that are not
// locks (sleeps, I/O, poll, pthread_join).
//
// Normal builds count, and so do GCC's sanitizer builds: their runtime is a shared library, after
// the executable, so the program's definitions come first and forward to its interceptors. Under
// clang's ThreadSanitizer, whose interceptors are in the executable and would be hidden, nothing
// is counted: lock_counting_available() says so and the tests print that they left their lock
// assertions out.
#pragma once

#include <cstdint>
#include <string_view>

namespace ioct::test_support {

// Lock and wait calls (see above) made so far by the calling thread, locks not counted aside.
std::uint64_t thread_lock_acquisitions() noexcept;
// How this build counts, or why it cannot, for a test's messages.
std::string_view lock_counting_method() noexcept;
// Whether this build counts locks at all.
bool lock_counting_available() noexcept;
// lock_counting_available(), and where it is not, a printed note saying why: for a test that then
// leaves out its lock assertion, so that it does not pass silently.
bool locks_are_counted_or_say_why() noexcept;

// Counts the calling thread's lock acquisitions from construction on. Use it on one thread only.
class LockCounter {
 public:
  LockCounter() noexcept : at_start_(thread_lock_acquisitions()) {}

  std::uint64_t acquisitions() const noexcept { return thread_lock_acquisitions() - at_start_; }

 private:
  std::uint64_t at_start_;
};

// While one is alive, the calling thread's lock acquisitions are not counted: for a test's fake of
// hardware, whose mutex stands in for what the real backend waits on (a GPIO line's poll(), a
// transfer's completion), so that a count taken across it is the code under test's alone. Nests.
class LocksNotCounted {
 public:
  LocksNotCounted() noexcept;
  ~LocksNotCounted();
  LocksNotCounted(const LocksNotCounted&) = delete;
  LocksNotCounted& operator=(const LocksNotCounted&) = delete;
};

}  // namespace ioct::test_support
