// Device time of work enqueued on a stream, by CUDA events: the one way the CUDA benchmarks time
// kernels and copies, so their figures are measured alike.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <vector>

#include "ioct/gpu/cuda/cuda_support.hpp"

namespace ioct::bench {

// Device milliseconds between an event before `work()` and one after it on `stream`, waited for.
template <class Work>
double device_ms(cudaStream_t stream, Work&& work) {
  gpu::cuda::TimingEvent start, stop;
  start.record(stream);
  work();
  stop.record(stream);
  stop.synchronize();
  return stop.ms_since(start);
}

// device_ms of `work(r)` for r = 0 .. warmup + repetitions - 1, keeping the last `repetitions`
// (the first runs pay for tables, plans and first launches).
template <class Work>
std::vector<double> device_ms_each(cudaStream_t stream, int warmup, int repetitions, Work&& work) {
  std::vector<double> times;
  times.reserve(static_cast<std::size_t>(repetitions));
  for (int r = 0; r < warmup + repetitions; ++r) {
    const double ms = device_ms(stream, [&] { work(r); });
    if (r >= warmup) times.push_back(ms);
  }
  return times;
}

// The anchor of every benchmark that moves groups to the device: milliseconds per pinned host ->
// device copy of `bytes`, back to back on one stream (the median of `repetitions` batches of 40,
// after one batch of warm-up).
double pinned_h2d_copy_ms(std::size_t bytes, int repetitions = 7);

}  // namespace ioct::bench
