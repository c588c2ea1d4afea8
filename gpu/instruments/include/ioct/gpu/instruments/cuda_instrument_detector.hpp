// The CUDA implementation of the instrument detection (built only with CUDA): per group, the
// B-scans (read in place from a device volume, or uploaded from a host one) are histogrammed by
// many blocks each (shared-memory histograms summed into one per B-scan; the last block of a
// B-scan takes its median, the floor), then every A-scan is classified by a warp against its
// B-scan's floor: column_classification.hpp's walks as ballots and warp reductions over the same
// integers, so the CPU reference's findings to the bit. The mask, reflexes and floors come back
// in one copy (a few bytes per A-scan), waited for in collect(), and the tips are found on the
// host, as for the CPU.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "ioct/gpu/cuda/cuda_support.hpp"
#include "ioct/gpu/cuda/pinned_download.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"

namespace ioct::gpu::instruments {

class CudaInstrumentDetector final : public InstrumentDetector {
 public:
  // Throws BackendUnavailable when there is no usable CUDA device (with CUDA's reason).
  CudaInstrumentDetector(const InstrumentConfig& config, const VolumeSampling& sampling);
  std::string_view backend_name() const noexcept override { return "cuda"; }

 private:
  void classify(VolumeRef volume, BscanSpan group, const ColumnParams& params,
                InstrumentFindings& findings) override;
  void collect(InstrumentFindings& findings) override;

  cuda::Stream stream_;
  cuda::Event volume_ready_;                // a device volume's writes so far
  cuda::DeviceArray<std::uint8_t> bscans_;  // the group's B-scans, uploaded from a host volume
  // [reflexes][fronts] (floats, [bscan of the group][ascan] each), [kinds][floors] (bytes)
  cuda::DeviceArray<float> results_;
  cuda::DeviceArray<std::uint32_t> histograms_;  // [bscan of the group][256], then parts done
  cuda::PinnedDownload download_;  // the group's kinds, reflexes, fronts and floors to the host
  struct InFlight {
    BscanSpan group;
    std::size_t ascans = 0;
  };
  std::optional<InFlight> in_flight_;  // classified on the stream, not collected yet
};

}  // namespace ioct::gpu::instruments
