// The CPU implementation of the OCT chain (FFTW): the reference the CUDA path is tested against,
// and the backend of machines without a GPU.
//
// Per group: the B-scans' spectra are summed per sample for the rolling background (one task
// per B-scan), then each output B-scan (each position, with repeats) is processed in batches of
// A-scans small enough to stay in cache: subtract the background, resample and window in one
// pass (times the dispersion correction when set), FFT the batch, map |X|^2 to u8 into the
// flipped column (or add it to the position's mean power when B-scans repeat). Positions are
// spread over a WorkerPool made in the constructor.
#pragma once

#include <complex>
#include <cstdint>
#include <optional>
#include <vector>

#include "ioct/gpu/processing/fftw_c2c_plan.hpp"
#include "ioct/gpu/processing/oct_processor.hpp"
#include "ioct/gpu/processing/spectral_tables.hpp"
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
  void set_db_range(const DbScaleConfig& scale) override;
  std::string_view backend_name() const noexcept override { return "cpu"; }

  // The spectrum subtracted from the last group (after process()).
  std::span<const float> last_background() const noexcept { return background_.background(); }

 private:
  // Scratch memory of one thread: one batch of spectra and their bins.
  struct Workspace {
    FftwArray<float> spectra;                        // real spectra (no dispersion)
    FftwArray<std::complex<float>> complex_spectra;  // with dispersion
    FftwArray<std::complex<float>> bins;
    std::vector<float> raw;    // one raw spectrum as float, for resampling
    std::vector<float> power;  // a position's summed power [column][depth], with repeats
  };

  void process_position(const RawGroup& group, ProcessedGroup& out, std::uint32_t position,
                        Workspace& workspace) const noexcept;
  // Fills row `row` of the workspace's batch from one raw spectrum.
  void make_spectrum(const std::uint16_t* raw, std::uint32_t row,
                     Workspace& workspace) const noexcept;
  void transform_batch(std::uint32_t count, Workspace& workspace) const noexcept;

  OctProcessorConfig config_;
  WorkerPool pool_;
  std::optional<shm::RingGeometry> geometry_;
  std::optional<SpectralTables> tables_;
  std::uint32_t depth_ = 0;
  std::uint32_t in_distance_ = 0;   // floats between spectra in a batch (64-byte multiple)
  std::uint32_t out_distance_ = 0;  // complex values between spectra's bins (64-byte multiple)
  CpuBackgroundEstimator background_;
  std::vector<float> windowed_background_;  // resampled background x window
  std::vector<Workspace> workspaces_;       // one per pool thread
  FftwR2cPlan batch_plan_;                  // kBatchAscans transforms
  FftwR2cPlan single_plan_;                 // one transform, for the rest of a B-scan
  FftwC2cPlan complex_batch_plan_;          // the same with dispersion
  FftwC2cPlan complex_single_plan_;
};

}  // namespace ioct::gpu
