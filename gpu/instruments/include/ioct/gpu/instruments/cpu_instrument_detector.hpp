// The CPU reference of the instrument detection: one B-scan per task on a WorkerPool.
#pragma once

#include "ioct/gpu/instruments/instrument_detector.hpp"
#include "ioct/gpu/worker_pool.hpp"

namespace ioct::gpu::instruments {

class CpuInstrumentDetector final : public InstrumentDetector {
 public:
  CpuInstrumentDetector(const InstrumentConfig& config, const VolumeSampling& sampling,
                        unsigned threads);
  std::string_view backend_name() const noexcept override { return "cpu"; }

 private:
  void classify(VolumeRef volume, BscanSpan group, const ColumnParams& params,
                InstrumentFindings& findings) override;

  WorkerPool pool_;
};

}  // namespace ioct::gpu::instruments
