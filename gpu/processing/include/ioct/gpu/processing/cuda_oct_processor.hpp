// The CUDA implementation of the OCT chain (cuFFT), the same interface as CpuOctProcessor and
// the same u8 pixels to within its FFT's rounding. Built only when the build has CUDA
// (IOCT_GPU_WITH_CUDA); this header needs no CUDA headers.
//
// Per group, all on one stream, five small kernels and one cuFFT call:
//   sum_spectra + update_background + windowed_background   (rolling background, integer sums)
//   make_spectra   raw - background, resampled, windowed, x dispersion correction (fused)
//   cuFFT          real-to-complex, or complex-to-complex with dispersion; one batched plan
//                  over the group's records, made in prepare()
//   log_u8         |X|^2 (mean over repeats) -> dB -> u8, flipped, into the target's B-scans
//
// Two ways in: process() from and to host memory (the OctProcessor interface, for tests and
// offline use), and enqueue_transform() + enqueue_pixels() on device memory, for the live
// pipeline, which copies groups straight from the ring and keeps the volume on the device.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ioct/gpu/processing/oct_processor.hpp"

struct CUstream_st;
struct CUevent_st;

namespace ioct::gpu {

// Where the u8 pixels of a group's output B-scans go in device memory: output B-scan o to
// B-scan position[o] of `pixels`, whose B-scans are the group's width x depth; -1 skips it.
struct DevicePixelTarget {
  std::uint8_t* pixels = nullptr;
  std::array<std::int32_t, shm::kMaxBscansPerGroup> position{};
};

class CudaOctProcessor final : public OctProcessor {
 public:
  // Validates the config (ConfigError) and checks the device: BackendUnavailable naming why it
  // cannot be used. Work goes to a new non-blocking stream on the current device.
  explicit CudaOctProcessor(const OctProcessorConfig& config);
  ~CudaOctProcessor() override;
  CudaOctProcessor(const CudaOctProcessor&) = delete;
  CudaOctProcessor& operator=(const CudaOctProcessor&) = delete;

  void prepare(const shm::RingGeometry& geometry) override;
  // Copies the spectra to the device, processes them and copies the pixels back; returns when
  // done. Throws std::runtime_error naming a failed CUDA call.
  void process(const RawGroup& group, ProcessedGroup& out) override;
  // Kernels already enqueued keep the range they were launched with.
  void set_db_range(const DbScaleConfig& scale) override;
  std::string_view backend_name() const noexcept override { return "cuda"; }

  // --- On device memory: everything is enqueued on stream(), in call order. ---

  CUstream_st* stream() const noexcept;
  std::uint32_t depth() const noexcept;

  // Enqueues the background update, the fused spectra kernel and the FFT of the group whose
  // payload is at `spectra` (device memory, the ring's layout), after `ready` (an event recorded
  // when the payload has arrived; nullptr: nothing to wait for). The header must have passed
  // find_group_problem(). Groups must come in acquisition order (rolling background).
  void enqueue_transform(const shm::SlotHeader& header, const std::uint16_t* spectra,
                         CUevent_st* ready);
  // Enqueues the pixels of output B-scans [first, last) of the group last transformed.
  void enqueue_pixels(const shm::SlotHeader& header, std::uint32_t first, std::uint32_t last,
                      const DevicePixelTarget& target);

  // The background subtracted from the last group, copied back (waits for the stream).
  std::vector<float> last_background() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ioct::gpu
