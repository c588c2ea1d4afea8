#include "device_timing.hpp"

#include "latency_summary.hpp"

namespace ioct::bench {

double pinned_h2d_copy_ms(std::size_t bytes, int repetitions) {
  gpu::cuda::PinnedArray<std::byte> host(bytes);
  gpu::cuda::DeviceArray<std::byte> device(bytes);
  gpu::cuda::Stream stream;
  constexpr int kCopies = 40;
  std::vector<double> batches = device_ms_each(stream.get(), 1, repetitions, [&](int) {
    for (int i = 0; i < kCopies; ++i) {
      IOCT_CUDA_CHECK(
          cudaMemcpyAsync(device.data(), host.data(), bytes, cudaMemcpyHostToDevice, stream.get()));
    }
  });
  return median(std::move(batches)) / kCopies;
}

}  // namespace ioct::bench
