#include "ioct/sim/synthesis_pipeline.hpp"

#include <pthread.h>
#include <sched.h>

#include <stdexcept>

#include "ioct/concurrency/monotonic_clock.hpp"

namespace ioct::sim {

SynthesisPipeline::SynthesisPipeline(std::uint32_t workers, std::uint32_t slots,
                                     std::uint32_t bscans_per_slot, BscanTask task,
                                     int fifo_priority)
    : bscans_(bscans_per_slot), task_(std::move(task)), slot_storage_(new Slot[slots]) {
  if (workers == 0 || slots == 0 || bscans_per_slot == 0) {
    throw std::invalid_argument("synthesis pipeline: workers, slots and B-scans must be > 0");
  }
  for (std::uint32_t s = 0; s < slots; ++s) {
    // Never dispatched: nothing to take, and not ready.
    slot_storage_[s].next.store(bscans_, std::memory_order_relaxed);
    slots_.push_back(&slot_storage_[s]);
  }
  threads_.reserve(workers);
  try {
    for (std::uint32_t w = 0; w < workers; ++w) {
      threads_.emplace_back([this, w] { work(w); });
      if (fifo_priority > 0) {
        sched_param param{};
        param.sched_priority = fifo_priority;
        if (::pthread_setschedparam(threads_.back().native_handle(), SCHED_FIFO, &param) == 0) {
          ++realtime_workers_;
        }
      }
    }
  } catch (...) {
    quit_.store(true);
    epoch_.fetch_add(1);
    epoch_.notify_all();
    for (std::thread& t : threads_) t.join();
    throw;
  }
}

SynthesisPipeline::~SynthesisPipeline() {
  cancel();
  quit_.store(true, std::memory_order_seq_cst);
  epoch_.fetch_add(1, std::memory_order_seq_cst);
  epoch_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void SynthesisPipeline::dispatch(std::uint32_t slot) noexcept {
  Slot& s = *slots_[slot];
  s.done.store(0, std::memory_order_relaxed);
  s.finished_ns.store(0, std::memory_order_relaxed);
  s.order.store(++dispatched_, std::memory_order_relaxed);
  // Release: a worker whose fetch_add reads this store sees the slot's inputs and the resets.
  s.next.store(0, std::memory_order_release);
  epoch_.fetch_add(1, std::memory_order_release);
  epoch_.notify_all();
}

bool SynthesisPipeline::ready(std::uint32_t slot) const noexcept {
  return slots_[slot]->done.load(std::memory_order_acquire) >= bscans_;
}

std::uint64_t SynthesisPipeline::finished_ns(std::uint32_t slot) const noexcept {
  return slots_[slot]->finished_ns.load(std::memory_order_relaxed);  // ordered by ready()
}

void SynthesisPipeline::cancel() noexcept {
  for (Slot* s : slots_) {
    // Leaves `next` >= bscans: the slot has nothing left to take and never becomes ready.
    s->next.fetch_add(bscans_, std::memory_order_acq_rel);
  }
}

std::uint32_t SynthesisPipeline::oldest_with_work() const noexcept {
  std::uint32_t best = slots();
  std::uint64_t best_order = 0;
  for (std::uint32_t i = 0; i < slots(); ++i) {
    const Slot& s = *slots_[i];
    if (s.next.load(std::memory_order_relaxed) >= bscans_) continue;
    const std::uint64_t order = s.order.load(std::memory_order_relaxed);
    if (best == slots() || order < best_order) {
      best = i;
      best_order = order;
    }
  }
  return best;
}

void SynthesisPipeline::work(std::uint32_t worker) noexcept {
  for (;;) {
    const std::uint64_t seen = epoch_.load(std::memory_order_acquire);
    if (quit_.load(std::memory_order_acquire)) return;
    bool worked = false;
    for (std::uint32_t slot = oldest_with_work(); slot < slots(); slot = oldest_with_work()) {
      busy_.fetch_add(1, std::memory_order_acq_rel);
      Slot& s = *slots_[slot];
      const std::uint32_t bscan = s.next.fetch_add(1, std::memory_order_acq_rel);
      if (bscan < bscans_) {
        task_(worker, slot, bscan);
        // Its end, kept if it is the latest, before the count that may release the slot.
        const std::uint64_t end = ioct::monotonic_ns();
        std::uint64_t latest = s.finished_ns.load(std::memory_order_relaxed);
        while (latest < end &&
               !s.finished_ns.compare_exchange_weak(latest, end, std::memory_order_relaxed)) {
        }
        // The last B-scan of the dispatch releases the whole slot to the owner.
        s.done.fetch_add(1, std::memory_order_acq_rel);
        worked = true;
      }
      busy_.fetch_sub(1, std::memory_order_acq_rel);
      if (quit_.load(std::memory_order_relaxed)) return;
    }
    // Nothing left: sleep until the next dispatch (or quit) changes the epoch.
    if (!worked) epoch_.wait(seen, std::memory_order_acquire);
  }
}

}  // namespace ioct::sim
