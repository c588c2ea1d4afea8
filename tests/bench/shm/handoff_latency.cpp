#include "handoff_latency.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "bench_ring_fixture.hpp"
#include "cpu_pinning.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace ioct::bench {
namespace {

// Spin politely: a pause on x86, and a yield when the two threads share one CPU.
void spin_pause(bool share_cpu) {
  if (share_cpu) {
    std::this_thread::yield();
    return;
  }
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#endif
}

void wait_until(std::uint64_t deadline_ns, bool share_cpu) {
  while (ioct::monotonic_ns() < deadline_ns) spin_pause(share_cpu);
}

struct CpuPlan {
  int writer = -1;
  int reader = -1;
  bool share_cpu = true;
};

CpuPlan plan_cpus() {
  const std::vector<int> cpus = allowed_cpus();
  if (cpus.size() < 2) return {};
  // The last two usable CPUs: CPU 0 takes most of the machine's interrupts.
  return {cpus[cpus.size() - 2], cpus[cpus.size() - 1], false};
}

// Runs writer and reader on their CPUs and joins both.
void run_pair(const CpuPlan& plan, const std::function<void()>& writer,
              const std::function<void()>& reader) {
  std::thread reader_thread([&] {
    if (plan.reader >= 0) pin_this_thread(plan.reader);
    reader();
  });
  std::thread writer_thread([&] {
    if (plan.writer >= 0) pin_this_thread(plan.writer);
    writer();
  });
  writer_thread.join();
  reader_thread.join();
}

// Each on its own cache line so the hand-off under test is the only traffic between them.
struct alignas(64) PaddedWord {
  std::atomic<std::uint64_t> value{0};
};

}  // namespace

HandoffLatencyResult measure_handoff_latency(std::uint64_t handoffs, std::uint64_t gap_ns,
                                             std::uint64_t slot_count) {
  const CpuPlan plan = plan_cpus();
  const std::uint64_t warmup = std::min<std::uint64_t>(handoffs / 10 + 1, 1000);
  const std::uint64_t total = warmup + handoffs;

  HandoffLatencyResult result;
  result.writer_cpu = plan.writer;
  result.reader_cpu = plan.reader;
  result.gap_ns = gap_ns;

  // The ring at the default geometry; the payload plays no part in a hand-off.
  BenchRing ring("handoff", shm::RingGeometry{}, slot_count, SlotFill::none);
  shm::RingReader reader = ring.attach_reader("bench-handoff");
  std::vector<std::uint64_t> ring_samples(handoffs, 1);
  std::vector<std::uint64_t> publish_samples(handoffs, 1);
  PaddedWord taken;  // groups the reader has taken so far
  shm::PollStatus unexpected = shm::PollStatus::ready;

  run_pair(
      plan,
      [&] {
        shm::RingWriter& writer = ring.writer();
        for (std::uint64_t i = 0; i < total; ++i) {
          while (taken.value.load(std::memory_order_acquire) < i) spin_pause(plan.share_cpu);
          wait_until(ioct::monotonic_ns() + gap_ns, plan.share_cpu);
          const std::uint64_t t0 = ioct::monotonic_ns();
          writer.publish(writer.claim());
          const std::uint64_t t1 = ioct::monotonic_ns();
          if (i >= warmup) publish_samples[i - warmup] = t1 - t0;
        }
      },
      [&] {
        shm::ReadTicket ticket;
        for (std::uint64_t i = 0; i < total; ++i) {
          shm::PollStatus status;
          while ((status = reader.begin_read(ticket)) == shm::PollStatus::empty) {
            spin_pause(plan.share_cpu);
          }
          const std::uint64_t now = ioct::monotonic_ns();
          if (status != shm::PollStatus::ready) {
            unexpected = status;                                  // reported after the join
            taken.value.store(total, std::memory_order_release);  // let the writer finish
            return;
          }
          reader.end_read(ticket);  // a false return is counted in the reader's drops
          if (i >= warmup) ring_samples[i - warmup] = now - ticket.header.t_publish_ns;
          taken.value.store(i + 1, std::memory_order_release);
        }
      });
  if (unexpected != shm::PollStatus::ready) {
    throw std::runtime_error("hand-off: begin_read answered " +
                             std::to_string(static_cast<int>(unexpected)) +
                             " instead of ready; the ring lost the writer");
  }
  result.ring = summarize(ring_samples);
  result.publish_with_reader = summarize(publish_samples);
  result.drops = reader.counters().dropped();

  // Anchor: a clock reading through one cache line, same protocol, same CPUs.
  PaddedWord stamp;
  PaddedWord anchor_taken;
  std::vector<std::uint64_t> anchor_samples(handoffs, 1);
  run_pair(
      plan,
      [&] {
        for (std::uint64_t i = 0; i < total; ++i) {
          while (anchor_taken.value.load(std::memory_order_acquire) < i) {
            spin_pause(plan.share_cpu);
          }
          wait_until(ioct::monotonic_ns() + gap_ns, plan.share_cpu);
          stamp.value.store(ioct::monotonic_ns(), std::memory_order_release);
        }
      },
      [&] {
        std::uint64_t last = 0;
        for (std::uint64_t i = 0; i < total; ++i) {
          std::uint64_t t = 0;
          while ((t = stamp.value.load(std::memory_order_acquire)) == last) {
            spin_pause(plan.share_cpu);
          }
          const std::uint64_t now = ioct::monotonic_ns();
          last = t;
          if (i >= warmup) anchor_samples[i - warmup] = now - t;
          anchor_taken.value.store(i + 1, std::memory_order_release);
        }
      });
  result.anchor_cache_line = summarize(anchor_samples);
  return result;
}

void print(const HandoffLatencyResult& r) {
  std::printf("writer -> reader hand-off, reader spinning on begin_read (default geometry)\n");
  if (r.writer_cpu >= 0) {
    std::printf("  writer on CPU %d, reader on CPU %d, %.1f us between hand-offs\n", r.writer_cpu,
                r.reader_cpu, static_cast<double>(r.gap_ns) / 1e3);
  } else {
    std::printf(
        "  ONE CPU ONLY: writer and reader share it (yielding); these figures measure "
        "the scheduler, not the ring\n");
  }
  std::printf("  %-34s %9s %9s %9s %9s\n", "", "p50 ns", "p99 ns", "p99.9 ns", "max ns");
  const auto row = [](const char* what, const LatencySummary& s) {
    std::printf("  %-34s %9.0f %9.0f %9.0f %9.0f\n", what, s.p50_ns, s.p99_ns, s.p999_ns, s.max_ns);
  };
  row("publish -> reader holds ticket", r.ring);
  row("anchor: clock through a cache line", r.anchor_cache_line);
  row("claim+publish, reader polling", r.publish_with_reader);
  std::printf("  ratio ring/anchor at p50: %.2f; groups dropped: %llu\n",
              r.anchor_cache_line.p50_ns > 0 ? r.ring.p50_ns / r.anchor_cache_line.p50_ns : 0.0,
              static_cast<unsigned long long>(r.drops));
}

nlohmann::json to_json(const HandoffLatencyResult& r) {
  return {{"writer_cpu", r.writer_cpu},
          {"reader_cpu", r.reader_cpu},
          {"gap_ns", r.gap_ns},
          {"handoff", to_json(r.ring)},
          {"anchor_cache_line", to_json(r.anchor_cache_line)},
          {"publish_with_reader_polling", to_json(r.publish_with_reader)},
          {"ratio_p50",
           r.anchor_cache_line.p50_ns > 0 ? r.ring.p50_ns / r.anchor_cache_line.p50_ns : 0.0},
          {"drops", r.drops}};
}

}  // namespace ioct::bench
