// A fixed pool of threads, made once at start-up, that runs the iterations of one loop at a time
// (e.g. the B-scans of a group). The calling thread works too, so a pool of 2 threads starts 1.
// The loop ends when its iterations are done, not when every worker has woken: a worker that
// wakes late (a sleeping thread can take a millisecond to run on some hosts) finds nothing left
// and costs the caller nothing.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

namespace ioct::gpu {

class WorkerPool {
 public:
  // threads >= 1, the caller included. Throws std::invalid_argument for 0. `worker_start`, if
  // given, runs first on each worker thread (e.g. to give the workers the owner's priority).
  explicit WorkerPool(unsigned threads, std::function<void()> worker_start = {});
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;
  ~WorkerPool();

  unsigned threads() const noexcept { return static_cast<unsigned>(workers_.size()) + 1; }

  // Calls task(index, worker) for every index in [0, count), spread over the threads; `worker`
  // (0 for the caller, then 1, 2, ...) lets a task use per-thread scratch memory. Returns when
  // every call has returned, then rethrows the first exception a call threw. Not reentrant.
  template <class Task>
  void run(std::uint32_t count, Task&& task) {
    using T = std::remove_reference_t<Task>;
    run_erased(count, const_cast<void*>(static_cast<const void*>(&task)),
               [](void* context, std::uint32_t index, unsigned worker) {
                 (*static_cast<T*>(context))(index, worker);
               });
  }

 private:
  using Call = void (*)(void*, std::uint32_t, unsigned);
  struct Job {
    void* context = nullptr;
    Call call = nullptr;
    std::uint32_t count = 0;
  };

  void run_erased(std::uint32_t count, void* context, Call call);
  void work_on(const Job& job, std::uint32_t generation, unsigned worker) noexcept;
  void worker_loop(unsigned worker) noexcept;

  std::mutex mutex_;
  std::condition_variable job_posted_;
  std::condition_variable job_done_;
  std::uint32_t generation_ = 0;  // bumped for every job
  Job job_;
  bool stopping_ = false;
  std::exception_ptr first_error_;
  // The job's generation (high 32 bits) and its next index (low 32 bits), taken together, so a
  // worker holding an older job can never take an index of a newer one.
  std::atomic<std::uint64_t> next_{0};
  std::atomic<std::uint32_t> completed_{0};  // iterations of the current job that returned
  std::vector<std::thread> workers_;
};

}  // namespace ioct::gpu
