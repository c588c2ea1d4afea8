// The concurrency toolbox's costs, each beside an anchor measured in the same run:
//  - SpscQueue throughput (items/s) with a producer and a consumer thread on two CPUs, against a
//    bounded std::deque behind a std::mutex carrying the same items between the same threads;
//  - LatencyHistogram::record() (ns per sample) against adding the same samples to one counter.
// Not a test: it prints figures (docs/BENCHMARKS.md); --items sets the queue's item count.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "cpu_pinning.hpp"
#include "ioct/concurrency/latency_histogram.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
#include "ioct/concurrency/spsc_queue.hpp"

namespace {

using ioct::monotonic_ns;

// The anchor: the simplest correct bounded queue between two threads.
class MutexQueue {
 public:
  explicit MutexQueue(std::size_t capacity) : capacity_(capacity) {}
  bool push(std::uint64_t v) {
    std::lock_guard lock(mutex_);
    if (items_.size() == capacity_) return false;
    items_.push_back(v);
    return true;
  }
  bool pop(std::uint64_t& v) {
    std::lock_guard lock(mutex_);
    if (items_.empty()) return false;
    v = items_.front();
    items_.pop_front();
    return true;
  }

 private:
  std::mutex mutex_;
  std::deque<std::uint64_t> items_;
  std::size_t capacity_;
};

struct Pair {
  int producer_cpu = -1;
  int consumer_cpu = -1;
};

// Items per second through `queue`; the consumer checks the order (exit 1 if broken).
template <typename Queue>
double items_per_second(Queue& queue, std::uint64_t items, Pair cpus, bool& in_order) {
  const std::uint64_t start = monotonic_ns();
  std::thread producer([&] {
    if (cpus.producer_cpu >= 0) ioct::bench::pin_this_thread(cpus.producer_cpu);
    for (std::uint64_t i = 0; i < items;) {
      if (queue.push(i)) ++i;
    }
  });
  if (cpus.consumer_cpu >= 0) ioct::bench::pin_this_thread(cpus.consumer_cpu);
  std::uint64_t expected = 0;
  while (expected < items) {
    std::uint64_t v = 0;
    if (!queue.pop(v)) continue;
    if (v != expected) in_order = false;
    ++expected;
  }
  producer.join();
  return static_cast<double>(items) * 1e9 / static_cast<double>(monotonic_ns() - start);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ioct-bench-concurrency: the SPSC queue and the latency histogram against anchors"};
  std::uint64_t items = 10'000'000;
  std::uint64_t samples = 10'000'000;
  int repeats = 3;
  app.add_option("--items", items, "items through each queue per repeat")
      ->check(CLI::Range(1000, 1'000'000'000));
  app.add_option("--samples", samples, "samples recorded per repeat")
      ->check(CLI::Range(1000, 1'000'000'000));
  app.add_option("--repeats", repeats, "repeats; the best of them is reported")
      ->check(CLI::Range(1, 100));
  CLI11_PARSE(app, argc, argv);

  const std::vector<int> cpus = ioct::bench::allowed_cpus();
  Pair pair;
  if (cpus.size() >= 2) {
    pair = {cpus[cpus.size() - 2], cpus[cpus.size() - 1]};
  } else {
    std::printf("only %zu usable CPU: the queue figures describe the scheduler\n", cpus.size());
  }

  bool in_order = true;
  double spsc = 0;
  double mutexed = 0;
  for (int r = 0; r < repeats; ++r) {
    ioct::SpscQueue<std::uint64_t> queue(1024);
    spsc = std::max(spsc, items_per_second(queue, items, pair, in_order));
    MutexQueue anchor(1024);
    mutexed = std::max(mutexed, items_per_second(anchor, items, pair, in_order));
  }
  std::printf(
      "SpscQueue<uint64_t>(1024): %.1f M items/s; anchor std::mutex + std::deque: %.1f M "
      "items/s; ratio %.1f (best of %d, %llu items, CPUs %d and %d)\n",
      spsc * 1e-6, mutexed * 1e-6, spsc / mutexed, repeats, static_cast<unsigned long long>(items),
      pair.producer_cpu, pair.consumer_cpu);

  // Log-uniform latencies from 100 ns to 10 ms, made before the timing.
  std::mt19937_64 random(5);
  std::uniform_real_distribution<double> exponent(2.0, 7.0);
  std::vector<std::uint64_t> values(4096);
  for (auto& v : values) v = static_cast<std::uint64_t>(std::pow(10.0, exponent(random)));
  double record_ns = 1e30;
  double add_ns = 1e30;
  std::uint64_t recorded = 0;
  for (int r = 0; r < repeats; ++r) {
    ioct::LatencyHistogram h;
    std::uint64_t t0 = monotonic_ns();
    for (std::uint64_t i = 0; i < samples; ++i) h.record(values[i & 4095]);
    std::uint64_t t1 = monotonic_ns();
    record_ns = std::min(record_ns, static_cast<double>(t1 - t0) / static_cast<double>(samples));
    recorded += h.count();
    volatile std::uint64_t total = 0;  // volatile: the anchor's loop is not folded away
    t0 = monotonic_ns();
    for (std::uint64_t i = 0; i < samples; ++i) total = total + values[i & 4095];
    t1 = monotonic_ns();
    add_ns = std::min(add_ns, static_cast<double>(t1 - t0) / static_cast<double>(samples));
  }
  std::printf(
      "LatencyHistogram::record: %.2f ns per sample; anchor (adding to one volatile counter): "
      "%.2f ns (best of %d, %llu samples recorded in all)\n",
      record_ns, add_ns, repeats, static_cast<unsigned long long>(recorded));
  if (!in_order) {
    std::printf("FAIL: items arrived out of order\n");
    return 1;
  }
  return 0;
}
