// Counts lock and wait calls per thread; see lock_counter.hpp for which. Each function below is
// the program's own definition of the glibc one: the dynamic linker binds every caller to it
// (the executable comes first in the lookup order, before libstdc++, libc and a sanitizer's
// runtime), and it counts, then forwards to the next definition, found with dlsym(RTLD_NEXT):
// glibc's, or the sanitizer's interceptor, which goes on to glibc's itself.
#include "ioct/test_support/lock_counter.hpp"

#include <dlfcn.h>
#include <linux/futex.h>
#include <pthread.h>
#include <semaphore.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "ioct/test_support/sanitizer_build.hpp"

namespace {

// initial-exec: reading these from inside the wrappers must not itself allocate or lock (the
// general dynamic TLS model may call __tls_get_addr).
__attribute__((tls_model("initial-exec"))) thread_local std::uint64_t t_lock_acquisitions = 0;
__attribute__((tls_model("initial-exec"))) thread_local std::uint32_t t_locks_not_counted = 0;

}  // namespace

namespace ioct::test_support {

std::uint64_t thread_lock_acquisitions() noexcept {
  return t_lock_acquisitions;
}

bool locks_are_counted_or_say_why() noexcept {
  if (lock_counting_available()) return true;
  std::printf("[ note     ] locks are not counted in this build (%.*s): lock assertion left out\n",
              static_cast<int>(lock_counting_method().size()), lock_counting_method().data());
  return false;
}

LocksNotCounted::LocksNotCounted() noexcept {
  ++t_locks_not_counted;
}
LocksNotCounted::~LocksNotCounted() {
  --t_locks_not_counted;
}

}  // namespace ioct::test_support

#if defined(IOCT_SANITIZER_INTERCEPTS_LOCKS_IN_EXECUTABLE)

namespace ioct::test_support {
std::string_view lock_counting_method() noexcept {
  return "none: clang's ThreadSanitizer runtime intercepts the pthread functions in the "
         "executable itself, where the counter's definitions would hide its interceptors";
}
bool lock_counting_available() noexcept {
  return false;
}
}  // namespace ioct::test_support

#else

namespace {

inline void count_lock() noexcept {
  if (t_locks_not_counted == 0) ++t_lock_acquisitions;
}

[[noreturn]] void die(const char* what, const char* name) noexcept {
  // write(2) only: no stdio (it locks) on a path that may run inside a lock call.
  static_cast<void>(::write(STDERR_FILENO, what, std::strlen(what)));
  static_cast<void>(::write(STDERR_FILENO, name, std::strlen(name)));
  static_cast<void>(::write(STDERR_FILENO, "\n", 1));
  std::abort();
}

// The definition of `Fn` that the one here hides. Resolved before main (see below), so that a
// counted path never runs dlsym (which takes the loader's lock and may allocate); resolved on
// first use when a library's constructor calls it before ours ran.
template <typename Fn>
class Next {
 public:
  explicit constexpr Next(const char* name) noexcept : name_(name) {}

  Fn* get() noexcept {
    Fn* fn = fn_.load(std::memory_order_relaxed);
    if (fn == nullptr) [[unlikely]] {
      fn = reinterpret_cast<Fn*>(::dlsym(RTLD_NEXT, name_));
      if (fn == nullptr) die("lock_counter: no next definition of ", name_);
      fn_.store(fn, std::memory_order_relaxed);
    }
    return fn;
  }

 private:
  const char* name_;
  std::atomic<Fn*> fn_{nullptr};
};

// The functions' types, spelt out: decltype of glibc's declarations would carry their nonnull
// attributes into the template arguments.
using LockMutex = int(pthread_mutex_t*);
using LockMutexUntil = int(pthread_mutex_t*, const timespec*);
using LockMutexUntilOnClock = int(pthread_mutex_t*, clockid_t, const timespec*);
using LockRwlock = int(pthread_rwlock_t*);
using LockRwlockUntil = int(pthread_rwlock_t*, const timespec*);
using LockRwlockUntilOnClock = int(pthread_rwlock_t*, clockid_t, const timespec*);
using LockSpin = int(pthread_spinlock_t*);
using WaitCondition = int(pthread_cond_t*, pthread_mutex_t*);
using WaitConditionUntil = int(pthread_cond_t*, pthread_mutex_t*, const timespec*);
using WaitConditionUntilOnClock = int(pthread_cond_t*, pthread_mutex_t*, clockid_t,
                                      const timespec*);
using WaitBarrier = int(pthread_barrier_t*);
using WaitSemaphore = int(sem_t*);
using WaitSemaphoreUntil = int(sem_t*, const timespec*);
using WaitSemaphoreUntilOnClock = int(sem_t*, clockid_t, const timespec*);
using SyscallWithSixArguments = long(long, long, long, long, long, long, long);

constinit Next<LockMutex> next_mutex_lock{"pthread_mutex_lock"};
constinit Next<LockMutexUntil> next_mutex_timedlock{"pthread_mutex_timedlock"};
constinit Next<LockMutexUntilOnClock> next_mutex_clocklock{"pthread_mutex_clocklock"};
constinit Next<LockRwlock> next_rwlock_rdlock{"pthread_rwlock_rdlock"};
constinit Next<LockRwlockUntil> next_rwlock_timedrdlock{"pthread_rwlock_timedrdlock"};
constinit Next<LockRwlockUntilOnClock> next_rwlock_clockrdlock{"pthread_rwlock_clockrdlock"};
constinit Next<LockRwlock> next_rwlock_wrlock{"pthread_rwlock_wrlock"};
constinit Next<LockRwlockUntil> next_rwlock_timedwrlock{"pthread_rwlock_timedwrlock"};
constinit Next<LockRwlockUntilOnClock> next_rwlock_clockwrlock{"pthread_rwlock_clockwrlock"};
constinit Next<LockSpin> next_spin_lock{"pthread_spin_lock"};
constinit Next<WaitCondition> next_cond_wait{"pthread_cond_wait"};
constinit Next<WaitConditionUntil> next_cond_timedwait{"pthread_cond_timedwait"};
constinit Next<WaitConditionUntilOnClock> next_cond_clockwait{"pthread_cond_clockwait"};
constinit Next<WaitBarrier> next_barrier_wait{"pthread_barrier_wait"};
constinit Next<WaitSemaphore> next_sem_wait{"sem_wait"};
constinit Next<WaitSemaphoreUntil> next_sem_timedwait{"sem_timedwait"};
constinit Next<WaitSemaphoreUntilOnClock> next_sem_clockwait{"sem_clockwait"};
constinit Next<SyscallWithSixArguments> next_syscall{"syscall"};

__attribute__((constructor(101))) void resolve_next_definitions() {
  next_mutex_lock.get();
  next_mutex_timedlock.get();
  next_mutex_clocklock.get();
  next_rwlock_rdlock.get();
  next_rwlock_timedrdlock.get();
  next_rwlock_clockrdlock.get();
  next_rwlock_wrlock.get();
  next_rwlock_timedwrlock.get();
  next_rwlock_clockwrlock.get();
  next_spin_lock.get();
  next_cond_wait.get();
  next_cond_timedwait.get();
  next_cond_clockwait.get();
  next_barrier_wait.get();
  next_sem_wait.get();
  next_sem_timedwait.get();
  next_sem_clockwait.get();
  next_syscall.get();
}

// The futex operations that may put the caller to sleep; the others (wake, requeue, trylock)
// return at once. `op` is an int the caller passed through `...`: only its low 32 bits are set.
bool futex_op_sleeps(long op) noexcept {
  switch (static_cast<int>(op) & FUTEX_CMD_MASK) {
    case FUTEX_WAIT:
    case FUTEX_WAIT_BITSET:
    case FUTEX_LOCK_PI:
#ifdef FUTEX_LOCK_PI2  // kernel headers from 5.14 on
    case FUTEX_LOCK_PI2:
#endif
    case FUTEX_WAIT_REQUEUE_PI:
      return true;
    default:
      return false;
  }
}

}  // namespace

namespace ioct::test_support {
std::string_view lock_counting_method() noexcept {
  return "pthread and futex-syscall interposition";
}
bool lock_counting_available() noexcept {
  return true;
}
}  // namespace ioct::test_support

// The exception specifications are glibc's: the waits that are cancellation points are not
// noexcept, so a thread cancelled inside one unwinds through here.
extern "C" {

int pthread_mutex_lock(pthread_mutex_t* mutex) noexcept {
  count_lock();
  return next_mutex_lock.get()(mutex);
}
int pthread_mutex_timedlock(pthread_mutex_t* mutex, const timespec* deadline) noexcept {
  count_lock();
  return next_mutex_timedlock.get()(mutex, deadline);
}
int pthread_mutex_clocklock(pthread_mutex_t* mutex, clockid_t clock,
                            const timespec* deadline) noexcept {
  count_lock();
  return next_mutex_clocklock.get()(mutex, clock, deadline);
}

int pthread_rwlock_rdlock(pthread_rwlock_t* lock) noexcept {
  count_lock();
  return next_rwlock_rdlock.get()(lock);
}
int pthread_rwlock_timedrdlock(pthread_rwlock_t* lock, const timespec* deadline) noexcept {
  count_lock();
  return next_rwlock_timedrdlock.get()(lock, deadline);
}
int pthread_rwlock_clockrdlock(pthread_rwlock_t* lock, clockid_t clock,
                               const timespec* deadline) noexcept {
  count_lock();
  return next_rwlock_clockrdlock.get()(lock, clock, deadline);
}
int pthread_rwlock_wrlock(pthread_rwlock_t* lock) noexcept {
  count_lock();
  return next_rwlock_wrlock.get()(lock);
}
int pthread_rwlock_timedwrlock(pthread_rwlock_t* lock, const timespec* deadline) noexcept {
  count_lock();
  return next_rwlock_timedwrlock.get()(lock, deadline);
}
int pthread_rwlock_clockwrlock(pthread_rwlock_t* lock, clockid_t clock,
                               const timespec* deadline) noexcept {
  count_lock();
  return next_rwlock_clockwrlock.get()(lock, clock, deadline);
}

int pthread_spin_lock(pthread_spinlock_t* lock) noexcept {
  count_lock();
  return next_spin_lock.get()(lock);
}

int pthread_cond_wait(pthread_cond_t* cond, pthread_mutex_t* mutex) {
  count_lock();
  return next_cond_wait.get()(cond, mutex);
}
int pthread_cond_timedwait(pthread_cond_t* cond, pthread_mutex_t* mutex, const timespec* deadline) {
  count_lock();
  return next_cond_timedwait.get()(cond, mutex, deadline);
}
int pthread_cond_clockwait(pthread_cond_t* cond, pthread_mutex_t* mutex, clockid_t clock,
                           const timespec* deadline) {
  count_lock();
  return next_cond_clockwait.get()(cond, mutex, clock, deadline);
}

int pthread_barrier_wait(pthread_barrier_t* barrier) noexcept {
  count_lock();
  return next_barrier_wait.get()(barrier);
}

int sem_wait(sem_t* semaphore) {
  count_lock();
  return next_sem_wait.get()(semaphore);
}
int sem_timedwait(sem_t* semaphore, const timespec* deadline) {
  count_lock();
  return next_sem_timedwait.get()(semaphore, deadline);
}
int sem_clockwait(sem_t* semaphore, clockid_t clock, const timespec* deadline) {
  count_lock();
  return next_sem_clockwait.get()(semaphore, clock, deadline);
}

// Every system call a program makes through syscall() passes here; only the futex waits count.
// It passes six arguments on whatever the caller gave, as glibc's syscall() itself does: the
// kernel reads only those the call has. Reading a slot the caller did not fill is not a bug here,
// so AddressSanitizer (clang's checks va_arg) is told not to look.
__attribute__((no_sanitize_address)) long syscall(long number, ...) noexcept {
  va_list list;
  va_start(list, number);
  long a[6];
  for (long& argument : a) argument = va_arg(list, long);
  va_end(list);
  if (number == SYS_futex && futex_op_sleeps(a[1])) count_lock();
#if defined(SYS_futex_waitv)
  if (number == SYS_futex_waitv) count_lock();
#endif
  return next_syscall.get()(number, a[0], a[1], a[2], a[3], a[4], a[5]);
}

}  // extern "C"

#endif
