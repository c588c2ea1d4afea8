// Worker threads that synthesise groups ahead of the acquisition thread, one B-scan per task.
//
// The owner (SimulatedDigitizer) keeps `slots` group buffers; it fills a slot's inputs, then
// dispatch()es it, and later polls ready(). Workers take the B-scans of the oldest dispatched
// slot first, each with a fetch_add on the slot's counter, and call the task for it; the last
// one to finish marks the slot ready. The owner's side (dispatch, ready, cancel) takes no lock,
// never waits and never allocates: it is safe on a real-time thread. Only an idle worker blocks
// (on an atomic wait), and dispatch wakes it with a futex wake, which does not block.
//
// Which worker draws which B-scan does not matter to the result: the task must depend only on
// (slot, bscan), never on the worker or on the order (the digitizer derives each B-scan's
// random stream from the seed and the B-scan's first sweep).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

namespace ioct::sim {

class SynthesisPipeline {
 public:
  // task(worker, slot, bscan): synthesise one B-scan of a dispatched slot. noexcept in effect:
  // an exception ends the process (std::terminate), as any in a worker thread would.
  using BscanTask =
      std::function<void(std::uint32_t worker, std::uint32_t slot, std::uint32_t bscan)>;

  // Starts `workers` (>= 1) threads, SCHED_FIFO at `fifo_priority` where > 0 and allowed.
  // Allocates; not for the real-time thread.
  SynthesisPipeline(std::uint32_t workers, std::uint32_t slots, std::uint32_t bscans_per_slot,
                    BscanTask task, int fifo_priority = 0);
  ~SynthesisPipeline();  // cancels and joins
  SynthesisPipeline(const SynthesisPipeline&) = delete;
  SynthesisPipeline& operator=(const SynthesisPipeline&) = delete;

  std::uint32_t workers() const noexcept { return static_cast<std::uint32_t>(threads_.size()); }
  std::uint32_t slots() const noexcept { return static_cast<std::uint32_t>(slots_.size()); }
  // Workers that run SCHED_FIFO (0 when no priority was asked or the host refused).
  std::uint32_t realtime_workers() const noexcept { return realtime_workers_; }

  // The slot's inputs are written: hand its B-scans to the workers. The slot must not be in
  // flight (ready, cancelled, or never dispatched). Lock-free, no allocation.
  void dispatch(std::uint32_t slot) noexcept;
  // Every B-scan of the slot's latest dispatch is done (acquire: its outputs are visible).
  bool ready(std::uint32_t slot) const noexcept;
  // When the slot's last B-scan was done (CLOCK_MONOTONIC ns); meaningful once ready().
  std::uint64_t finished_ns(std::uint32_t slot) const noexcept;
  // Withdraws the B-scans no worker has taken yet from every slot (the slots never become
  // ready); B-scans already running finish. Lock-free.
  void cancel() noexcept;
  // True when no worker is inside a task (after cancel(): the slots may be rewritten).
  bool idle() const noexcept { return busy_.load(std::memory_order_acquire) == 0; }

 private:
  struct alignas(64) Slot {
    std::atomic<std::uint32_t> next{0};         // the next B-scan to take; >= bscans: none left
    std::atomic<std::uint32_t> done{0};         // B-scans finished in this dispatch
    std::atomic<std::uint64_t> order{0};        // dispatch sequence: the oldest is served first
    std::atomic<std::uint64_t> finished_ns{0};  // the latest B-scan's end, CLOCK_MONOTONIC
  };

  void work(std::uint32_t worker) noexcept;
  // The dispatched slot with B-scans left and the lowest order, or slots() if none.
  std::uint32_t oldest_with_work() const noexcept;

  std::uint32_t bscans_;
  BscanTask task_;
  std::unique_ptr<Slot[]> slot_storage_;
  std::vector<Slot*> slots_;
  std::uint64_t dispatched_ = 0;         // owner's thread only
  std::atomic<std::uint64_t> epoch_{0};  // bumped on every dispatch: wakes the workers
  std::atomic<std::uint32_t> busy_{0};   // workers inside a task
  std::atomic<bool> quit_{false};
  std::uint32_t realtime_workers_ = 0;
  std::vector<std::thread> threads_;
};

}  // namespace ioct::sim
