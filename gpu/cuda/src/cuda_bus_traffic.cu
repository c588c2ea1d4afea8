// The counted host <-> device copy of cuda_support.hpp.
#include <atomic>

#include "ioct/gpu/cuda/cuda_support.hpp"

namespace ioct::gpu::cuda {
namespace {

struct Counters {
  std::atomic<std::uint64_t> volume_to_device{0}, volume_to_host{0};
  std::atomic<std::uint64_t> other_to_device{0}, other_to_host{0};
};
Counters counters;

}  // namespace

BusTraffic bus_traffic() noexcept {
  BusTraffic t;
  t.volume_to_device = counters.volume_to_device.load(std::memory_order_relaxed);
  t.volume_to_host = counters.volume_to_host.load(std::memory_order_relaxed);
  t.other_to_device = counters.other_to_device.load(std::memory_order_relaxed);
  t.other_to_host = counters.other_to_host.load(std::memory_order_relaxed);
  return t;
}

void copy_async(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind kind,
                cudaStream_t stream, Payload payload, const char* what) {
  check(cudaMemcpyAsync(dst, src, bytes, kind, stream), what);
  const bool volume = payload == Payload::volume;
  if (kind == cudaMemcpyHostToDevice) {
    (volume ? counters.volume_to_device : counters.other_to_device)
        .fetch_add(bytes, std::memory_order_relaxed);
  } else if (kind == cudaMemcpyDeviceToHost) {
    (volume ? counters.volume_to_host : counters.other_to_host)
        .fetch_add(bytes, std::memory_order_relaxed);
  }
}

}  // namespace ioct::gpu::cuda
