// The CPU implementation of the OCT chain (FFTW): the reference the CUDA path is tested against,
// and the backend of machines without a GPU.
//
// Per group: the B-scans' spectra are summed per sample for the background (one task per
// B-scan), then each B-scan is processed in batches of A-scans small enough to stay in cache:
// subtract background and window in one pass, FFT the batch, map |X|^2 to u8 into the flipped
// column. B-scans are spread over a WorkerPool made in the constructor.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "ioct/gpu/oct_processor.hpp"
#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu {

class CpuOctProcessor final : public OctProcessor {
 public:
  // A-scans transformed per FFT call.
  static constexpr std::uint32_t kBatchAscans = 16;

  // Validates the config (ConfigError) and starts the pool's threads.
  explicit CpuOctProcessor(const OctProcessorConfig& config);

  void prepare(const shm::RingGeometry& geometry) override;
  void process(const RawGroup& group, ProcessedGroup& out) override;
  std::string_view backend_name() const noexcept override { return "cpu"; }

  // The spectrum subtracted from the last group (after process()).
  std::span<const float> last_background() const noexcept { return background_.background(); }

 private:
  // Scratch memory of one thread: one batch of windowed spectra and their bins.
  struct Workspace {
    FftwArray<float> spectra;
    FftwArray<std::complex<float>> bins;
  };

  void process_bscan(const RawGroup& group, ProcessedGroup& out, std::uint32_t bscan,
                     Workspace& workspace) const noexcept;

  OctProcessorConfig config_;
  WorkerPool pool_;
  std::optional<shm::RingGeometry> geometry_;
  std::uint32_t depth_ = 0;
  std::uint32_t in_distance_ = 0;   // floats between spectra in a batch (64-byte multiple)
  std::uint32_t out_distance_ = 0;  // complex values between spectra's bins (64-byte multiple)
  CpuBackgroundEstimator background_;
  std::vector<float> window_;
  std::vector<float> windowed_background_;  // background x window, subtracted after windowing
  std::optional<DbToU8> scale_;
  std::vector<Workspace> workspaces_;  // one per pool thread
  FftwR2cPlan batch_plan_;             // kBatchAscans transforms
  FftwR2cPlan single_plan_;            // one transform, for the rest of a B-scan
};

}  // namespace ioct::gpu
