#include "ioct/gpu/instruments/instrument_detector.hpp"

#include <stdexcept>
#include <string>
#include <utility>

#include "ioct/gpu/instruments/cpu_instrument_detector.hpp"
#if IOCT_INSTRUMENTS_HAVE_CUDA
#include "ioct/gpu/instruments/cuda_instrument_detector.hpp"
#endif

namespace ioct::gpu::instruments {

InstrumentDetector::InstrumentDetector(const InstrumentConfig& config,
                                       const VolumeSampling& sampling)
    : config_(config), sampling_(sampling) {
  config_.validate();
  sampling_.validate();
}

void InstrumentDetector::detect_group(VolumeRef volume, BscanSpan group,
                                      const segmentation::Surfaces& surfaces,
                                      InstrumentFindings& findings) {
  begin_group(volume, group, findings);
  end_group(surfaces, findings);
}

void InstrumentDetector::begin_group(VolumeRef volume, BscanSpan group,
                                     InstrumentFindings& findings) {
  drop_group();
  const VolumeDims& dims = volume.dims();
  if (group.end() > dims.bscans || group.end() < group.first) {
    throw std::out_of_range("instruments: B-scans [" + std::to_string(group.first) + ", " +
                            std::to_string(group.first + group.count) + ") outside a volume of " +
                            std::to_string(dims.bscans) + " B-scans");
  }
  if (dims.depth == 0 && dims.bscans > 0) {
    throw std::invalid_argument("instruments: a volume of no depth");
  }
  if (findings.bscans != dims.bscans || findings.ascans != dims.ascans) {
    findings.reset(dims.bscans, dims.ascans);
  }
  if (group.count > 0) {
    classify(volume, group, make_column_params(config_, sampling_, dims.depth), findings);
  }
  pending_ = &findings;
}

void InstrumentDetector::check_pending(const InstrumentFindings& findings, const char* call) const {
  if (pending_ == nullptr) {
    throw std::logic_error(std::string("instruments: ") + call + " with no group begun");
  }
  if (pending_ != &findings) {
    throw std::logic_error(std::string("instruments: ") + call +
                           " for other findings than begin_group()'s");
  }
}

void InstrumentDetector::locate_tips(InstrumentFindings& findings) {
  check_pending(findings, "locate_tips()");
  if (located_) throw std::logic_error("instruments: locate_tips() twice for one group");
  try {
    collect(findings);
    tip_finder_.locate(findings, config_, sampling_);
  } catch (...) {
    drop_group();  // nothing half done is left to end: end_group() then says none is begun
    throw;
  }
  located_ = true;
}

void InstrumentDetector::end_group(const segmentation::Surfaces& surfaces,
                                   InstrumentFindings& findings) {
  check_pending(findings, "end_group()");
  pending_ = nullptr;
  if (!std::exchange(located_, false)) {
    collect(findings);
    tip_finder_.locate(findings, config_, sampling_);
  }
  tip_finder_.place(findings, surfaces, config_, sampling_);
}

void InstrumentDetector::drop_group() {
  InstrumentFindings* const pending = std::exchange(pending_, nullptr);
  if (pending == nullptr) return;
  // Its classes are collected (the device is done with the volume) unless its tips were
  // located; its tips, and any earlier group's, are cleared.
  if (!std::exchange(located_, false)) collect(*pending);
  pending->tips.clear();
  pending->nearest = -1;
  pending->warning = false;
}

void InstrumentDetector::detect_volume(const Volume& volume, const segmentation::Surfaces& surfaces,
                                       InstrumentFindings& findings) {
  drop_group();  // before the reset: a pending group's classes go where it began
  findings.reset(volume.bscans(), volume.ascans());
  detect_group(volume, {0, volume.bscans()}, surfaces, findings);
}

std::unique_ptr<InstrumentDetector> make_instrument_detector(Backend backend,
                                                             const InstrumentConfig& config,
                                                             const VolumeSampling& sampling,
                                                             unsigned cpu_threads) {
  config.validate();
  sampling.validate();
  if (backend == Backend::cpu) {
    return std::make_unique<CpuInstrumentDetector>(config, sampling, cpu_threads);
  }
#if IOCT_INSTRUMENTS_HAVE_CUDA
  if (backend == Backend::cuda) return std::make_unique<CudaInstrumentDetector>(config, sampling);
  try {
    return std::make_unique<CudaInstrumentDetector>(config, sampling);
  } catch (const BackendUnavailable&) {
    return std::make_unique<CpuInstrumentDetector>(config, sampling, cpu_threads);
  }
#else
  if (backend == Backend::cuda) {
    throw BackendUnavailable(
        "backend cuda: this build has no CUDA instrument detection; use the cpu backend");
  }
  return std::make_unique<CpuInstrumentDetector>(config, sampling, cpu_threads);
#endif
}

}  // namespace ioct::gpu::instruments
