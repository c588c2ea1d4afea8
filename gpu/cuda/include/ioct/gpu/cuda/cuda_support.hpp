// The CUDA support every CUDA part of gpu/ shares (only included when the build has CUDA): checked
// calls that name what failed and where, owners of device memory, pinned memory, streams and
// events so that every exit path gives them back (move-only: a copy would free twice), and the
// one copy wrapper through which the stages move bytes between host and device, counted so that
// tests can tell what crossed the bus.
#pragma once

#include <cuda_runtime.h>
#include <cufft.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

#include "ioct/common/error.hpp"

namespace ioct::gpu::cuda {

std::string describe(cudaError_t status);
std::string describe(cufftResult status);

// A CUDA runtime or cuFFT call that failed: category device (ioct/common/error.hpp), with the
// status it returned so a caller can tell an out-of-memory from a lost device.
class CudaError : public std::runtime_error, public Error {
 public:
  CudaError(const std::string& message, cudaError_t status)
      : std::runtime_error(message), Error(ErrorCategory::device), status_(status) {}
  CudaError(const std::string& message, cufftResult status)
      : std::runtime_error(message), Error(ErrorCategory::device), cufft_status_(status) {}
  // cudaSuccess for a cuFFT error, and CUFFT_SUCCESS for a runtime one.
  cudaError_t status() const noexcept { return status_; }
  cufftResult cufft_status() const noexcept { return cufft_status_; }

 private:
  cudaError_t status_ = cudaSuccess;
  cufftResult cufft_status_ = CUFFT_SUCCESS;
};

// Throws CudaError "<what> failed: <error name> (<error text>)".
inline void check(cudaError_t status, const char* what) {
  if (status != cudaSuccess)
    throw CudaError(std::string(what) + " failed: " + describe(status), status);
}
inline void check(cufftResult status, const char* what) {
  if (status != CUFFT_SUCCESS) {
    throw CudaError(std::string(what) + " failed: " + describe(status), status);
  }
}

// Throws CudaError "<file>:<line>: <what> failed: <error name> (<error text>)".
inline void check(cudaError_t status, const char* what, const char* file, int line) {
  if (status != cudaSuccess) {
    throw CudaError(std::string(file) + ":" + std::to_string(line) + ": " + what +
                        " failed: " + describe(status),
                    status);
  }
}
inline void check(cufftResult status, const char* what, const char* file, int line) {
  if (status != CUFFT_SUCCESS) {
    throw CudaError(std::string(file) + ":" + std::to_string(line) + ": " + what +
                        " failed: " + describe(status),
                    status);
  }
}

#define IOCT_CUDA_CHECK(call) ::ioct::gpu::cuda::check((call), #call, __FILE__, __LINE__)

// The last launch's error, if any (launches return nothing themselves).
inline void check_launch(const char* kernel) {
  check(cudaGetLastError(), kernel);
}

template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(std::size_t count) : count_(count), capacity_(count) {
    if (count > 0) IOCT_CUDA_CHECK(cudaMalloc(&data_, count * sizeof(T)));
  }
  DeviceArray(DeviceArray&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)),
        count_(std::exchange(other.count_, 0)),
        capacity_(std::exchange(other.capacity_, 0)) {}
  DeviceArray& operator=(DeviceArray&& other) noexcept {
    if (this != &other) {
      if (data_ != nullptr) cudaFree(data_);
      data_ = std::exchange(other.data_, nullptr);
      count_ = std::exchange(other.count_, 0);
      capacity_ = std::exchange(other.capacity_, 0);
    }
    return *this;
  }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  ~DeviceArray() {
    if (data_ != nullptr) cudaFree(data_);
  }
  T* data() const noexcept { return data_; }
  std::size_t size() const noexcept { return count_; }
  std::size_t bytes() const noexcept { return count_ * sizeof(T); }
  // `count` elements; a resize past the allocation loses the contents. The allocation only
  // grows: cudaFree waits for the whole device, so a buffer that alternates between sizes (a
  // volume's pass, then a group's) must not free on every change.
  void resize(std::size_t count) {
    if (count == count_) return;
    if (count > capacity_) {
      *this = DeviceArray();
      *this = DeviceArray(count);
    }
    count_ = count;
  }
  std::size_t capacity() const noexcept { return capacity_; }

 private:
  T* data_ = nullptr;
  std::size_t count_ = 0;
  std::size_t capacity_ = 0;
};

template <class T>
class PinnedArray {
 public:
  PinnedArray() = default;
  explicit PinnedArray(std::size_t count) : count_(count), capacity_(count) {
    if (count > 0) IOCT_CUDA_CHECK(cudaMallocHost(&data_, count * sizeof(T)));
  }
  PinnedArray(PinnedArray&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)),
        count_(std::exchange(other.count_, 0)),
        capacity_(std::exchange(other.capacity_, 0)) {}
  PinnedArray& operator=(PinnedArray&& other) noexcept {
    if (this != &other) {
      if (data_ != nullptr) cudaFreeHost(data_);
      data_ = std::exchange(other.data_, nullptr);
      count_ = std::exchange(other.count_, 0);
      capacity_ = std::exchange(other.capacity_, 0);
    }
    return *this;
  }
  PinnedArray(const PinnedArray&) = delete;
  PinnedArray& operator=(const PinnedArray&) = delete;
  ~PinnedArray() {
    if (data_ != nullptr) cudaFreeHost(data_);
  }
  T* data() const noexcept { return data_; }
  std::size_t size() const noexcept { return count_; }
  // `count` elements; a resize past the allocation loses the contents. The allocation only
  // grows: cudaFreeHost waits for the whole device, so a buffer that alternates between sizes
  // must not free on every change.
  void resize(std::size_t count) {
    if (count == count_) return;
    if (count > capacity_) {
      *this = PinnedArray();
      *this = PinnedArray(count);
    }
    count_ = count;
  }
  std::size_t capacity() const noexcept { return capacity_; }

 private:
  T* data_ = nullptr;
  std::size_t count_ = 0;
  std::size_t capacity_ = 0;
};

class Stream {
 public:
  Stream() { IOCT_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking)); }
  ~Stream() { cudaStreamDestroy(stream_); }
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;
  cudaStream_t get() const noexcept { return stream_; }

 private:
  cudaStream_t stream_ = nullptr;
};

class Event {
 public:
  // Timing off: these events only order work and say when it is done.
  Event() { IOCT_CUDA_CHECK(cudaEventCreateWithFlags(&event_, cudaEventDisableTiming)); }
  ~Event() {
    if (event_ != nullptr) cudaEventDestroy(event_);
  }
  Event(Event&& other) noexcept : event_(std::exchange(other.event_, nullptr)) {}
  Event& operator=(Event&&) = delete;
  Event(const Event&) = delete;
  Event& operator=(const Event&) = delete;
  cudaEvent_t get() const noexcept { return event_; }
  // True when the work recorded last has completed; throws for an error.
  bool done() const {
    const cudaError_t status = cudaEventQuery(event_);
    if (status == cudaErrorNotReady) return false;
    check(status, "cudaEventQuery");
    return true;
  }

 private:
  cudaEvent_t event_ = nullptr;
};

// An event that measures time (Event only orders work): between two recorded on the device.
class TimingEvent {
 public:
  TimingEvent() { IOCT_CUDA_CHECK(cudaEventCreate(&event_)); }
  ~TimingEvent() { cudaEventDestroy(event_); }
  TimingEvent(const TimingEvent&) = delete;
  TimingEvent& operator=(const TimingEvent&) = delete;
  void record(cudaStream_t stream) { IOCT_CUDA_CHECK(cudaEventRecord(event_, stream)); }
  void synchronize() const { IOCT_CUDA_CHECK(cudaEventSynchronize(event_)); }
  // Device time from `earlier` to this one, ms (both recorded and done).
  float ms_since(const TimingEvent& earlier) const {
    float ms = 0.0f;
    IOCT_CUDA_CHECK(cudaEventElapsedTime(&ms, earlier.event_, event_));
    return ms;
  }
  cudaEvent_t get() const noexcept { return event_; }

 private:
  cudaEvent_t event_ = nullptr;
};

// What a copy between host and device carries: volume pixels, or anything else (surfaces,
// tables, sums, images).
enum class Payload { volume, other };

// Bytes copied through copy_async since the process started, by direction and payload.
struct BusTraffic {
  std::uint64_t volume_to_device = 0, volume_to_host = 0;
  std::uint64_t other_to_device = 0, other_to_host = 0;
};
BusTraffic bus_traffic() noexcept;

// cudaMemcpyAsync on `stream`, checked (naming `what`), host <-> device copies counted in
// bus_traffic(); device-to-device copies are not counted.
void copy_async(void* dst, const void* src, std::size_t bytes, cudaMemcpyKind kind,
                cudaStream_t stream, Payload payload, const char* what);

}  // namespace ioct::gpu::cuda
