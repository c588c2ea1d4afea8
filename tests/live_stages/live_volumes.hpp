// The live volumes the stages' tests hand over: fake LiveVolumeSources, on the host and (CUDA
// builds) on the device as the CUDA live pipeline's (layered_volume.hpp has the speckled layered
// volume they fill it with).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#if IOCT_GPU_WITH_CUDA
#include <cuda_runtime.h>
#endif

#include "ioct/gpu/ingest/live_stage.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "layered_volume.hpp"

namespace ioct::gpu::live {

// A live volume the test writes into, copied out by copy_bscans as the pipelines do it; with
// `on_device`, also kept on the device (after each written()) and read there (read_on_device), as
// the CUDA live pipeline's volume is.
class FakeLiveVolume final : public LiveVolumeSource {
 public:
  explicit FakeLiveVolume(bool on_device = false) : on_device_(on_device) {}
  ~FakeLiveVolume() override {
#if IOCT_GPU_WITH_CUDA
    if (device_ != nullptr) cudaFree(device_);
#endif
  }
  FakeLiveVolume(const FakeLiveVolume&) = delete;
  FakeLiveVolume& operator=(const FakeLiveVolume&) = delete;

  Volume volume;

  // B-scans [first, first + count) of `volume` were written: the device copy follows (plain
  // cudaMemcpy, outside the stages' counted copies: this is the pipeline's ingest).
  void written(std::uint32_t first, std::uint32_t count) {
#if IOCT_GPU_WITH_CUDA
    if (!on_device_) return;
    if (device_bytes_ != volume.pixels().size()) {
      if (device_ != nullptr) cudaFree(device_);
      device_ = nullptr;
      ASSERT_EQ(cudaMalloc(&device_, volume.pixels().size()), cudaSuccess);
      device_bytes_ = volume.pixels().size();
      first = 0;
      count = volume.bscans();
    }
    const std::size_t n = volume.bscan_pixels();
    ASSERT_EQ(cudaMemcpy(device_ + first * n, volume.bscan(first).data(), count * n,
                         cudaMemcpyHostToDevice),
              cudaSuccess);
#else
    (void)first;
    (void)count;
#endif
  }

  LiveVolumeShape shape() const override {
    return {volume.bscans(), volume.ascans(), volume.depth()};
  }
  void copy_bscans(std::uint32_t first, std::uint32_t count, Volume& out) override {
    prepare_bscan_copy(shape(), first, count, out);
    const std::size_t n = volume.bscan_pixels();
    std::copy_n(volume.bscan(first).data(), count * n, out.bscan(first).data());
  }
  bool read_on_device(CUstream_st* /*stream*/,
                      const std::function<void(const DeviceVolumeView&)>& enqueue_reads) override {
    if (!on_device_) return false;
    enqueue_reads({device_, volume.bscans(), volume.ascans(), volume.depth(), 0});
    return true;
  }

 private:
  bool on_device_;
  std::uint8_t* device_ = nullptr;
  std::size_t device_bytes_ = 0;
};

}  // namespace ioct::gpu::live
