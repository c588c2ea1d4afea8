// The CUDA support's buffers (gpu/cuda): a resize within what is allocated keeps the allocation
// and does not wait for the device (cudaFree would: a buffer that alternates between a volume's
// size and a group's stalled every stream at each change), a larger one allocates anew, a move
// takes the allocation along; the pinned download reads back each of several sizes exactly.
// Skipped, saying why, where the cuda backend cannot run.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <numeric>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "ioct/gpu/cuda/backend.hpp"
#if IOCT_GPU_WITH_CUDA
#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/pinned_download.hpp"
#endif

namespace ioct::gpu::cuda {
namespace {

class CudaSupport : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::optional<std::string> reason = cuda_unavailable_reason()) {
      GTEST_SKIP() << "cuda backend not tested: " << *reason;
    }
  }
};

#if IOCT_GPU_WITH_CUDA

// A stream held by a host function until the test releases it (or 5 s pass, so that a resize
// that does wait for the device ends the test with a failure rather than a hang).
class HeldStream {
 public:
  HeldStream() {
    EXPECT_EQ(cudaLaunchHostFunc(stream_.get(), &HeldStream::hold, this), cudaSuccess);
  }
  ~HeldStream() {
    release();
    cudaStreamSynchronize(stream_.get());
  }
  void release() { released_ = true; }
  bool ran_out() const { return ran_out_; }
  cudaStream_t get() const { return stream_.get(); }

 private:
  static void CUDART_CB hold(void* self) {
    auto* held = static_cast<HeldStream*>(self);
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (!held->released_) {
      if (std::chrono::steady_clock::now() > until) {
        held->ran_out_ = true;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  Stream stream_;
  std::atomic<bool> released_{false}, ran_out_{false};
};

// `values` (a DeviceArray or PinnedArray) resized to `count`, within its allocation, while a
// stream is held: the stream stays held, the block and the allocation stay, the size follows.
template <class Array>
void expect_shrink_keeps_the_block_and_waits_for_nothing(Array& values, std::size_t count) {
  const auto* const block = values.data();
  const std::size_t capacity = values.capacity();
  ASSERT_NE(block, nullptr);
  {
    HeldStream held;
    values.resize(count);
    EXPECT_FALSE(held.ran_out()) << "the shrink waited for the held stream";
    EXPECT_EQ(cudaStreamQuery(held.get()), cudaErrorNotReady);
    held.release();
  }
  EXPECT_EQ(values.data(), block);
  EXPECT_EQ(values.size(), count);
  EXPECT_EQ(values.capacity(), capacity);
}

#endif

TEST_F(CudaSupport, DeviceArrayShrinksWithinItsAllocationWithoutWaitingForTheDevice) {
#if IOCT_GPU_WITH_CUDA
  DeviceArray<float> values(1000);
  float* const first = values.data();
  expect_shrink_keeps_the_block_and_waits_for_nothing(values, 100);
  EXPECT_EQ(values.bytes(), 100u * sizeof(float));
  EXPECT_EQ(values.capacity(), 1000u);

  // Back up within the allocation: the same block, every element usable.
  values.resize(1000);
  EXPECT_EQ(values.data(), first);
  std::vector<float> in(1000), out(1000, -1.0f);
  std::iota(in.begin(), in.end(), 0.5f);
  ASSERT_EQ(cudaMemcpy(values.data(), in.data(), values.bytes(), cudaMemcpyHostToDevice),
            cudaSuccess);
  ASSERT_EQ(cudaMemcpy(out.data(), values.data(), values.bytes(), cudaMemcpyDeviceToHost),
            cudaSuccess);
  EXPECT_EQ(out, in);

  // Past it: a new allocation of the new size.
  values.resize(5000);
  EXPECT_EQ(values.size(), 5000u);
  EXPECT_EQ(values.capacity(), 5000u);

  DeviceArray<float> moved = std::move(values);
  EXPECT_EQ(moved.capacity(), 5000u);
  EXPECT_EQ(values.capacity(), 0u);  // NOLINT(bugprone-use-after-move): the moved-from state
  EXPECT_EQ(values.data(), nullptr);
  values.resize(10);  // a moved-from array allocates again
  EXPECT_NE(values.data(), nullptr);
  EXPECT_EQ(values.capacity(), 10u);
#endif
}

TEST_F(CudaSupport, PinnedArrayShrinksWithinItsAllocationWithoutWaitingForTheDevice) {
#if IOCT_GPU_WITH_CUDA
  PinnedArray<std::uint16_t> values(4096);
  expect_shrink_keeps_the_block_and_waits_for_nothing(values, 16);
  EXPECT_EQ(values.capacity(), 4096u);
  values.resize(4097);
  EXPECT_EQ(values.capacity(), 4097u);
  EXPECT_EQ(values.size(), 4097u);
#endif
}

// One download after another of other sizes, smaller and larger, through the block it keeps:
// each reads back exactly what its device range holds, none of the last one's bytes.
TEST_F(CudaSupport, PinnedDownloadReadsBackEachSizeAfterLargerAndSmallerOnes) {
#if IOCT_GPU_WITH_CUDA
  Stream stream;
  PinnedDownload download;
  for (const std::size_t count : {4096u, 16u, 1000u, 8192u, 3u}) {
    std::vector<std::int32_t> in(count);
    std::iota(in.begin(), in.end(), static_cast<std::int32_t>(count));
    DeviceArray<std::int32_t> device(count);
    ASSERT_EQ(cudaMemcpy(device.data(), in.data(), device.bytes(), cudaMemcpyHostToDevice),
              cudaSuccess);
    const std::size_t piece = download.add(device.data(), device.bytes());
    download.fetch(stream.get(), Payload::other, "the test's values");
    std::vector<std::int32_t> out;
    download.take(piece, out);
    EXPECT_EQ(out, in) << count << " values";
  }
#endif
}

}  // namespace
}  // namespace ioct::gpu::cuda
