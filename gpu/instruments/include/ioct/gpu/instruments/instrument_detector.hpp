// Instrument detection: one interface with a CPU reference and a CUDA implementation that give
// the same shadow mask and reflexes (the column classification is the same integer code on both);
// the tips and distances are then found on the host from the mask (tip_finder.hpp).
//
// Per group of new B-scans: each B-scan's noise floor (the median of its px), then every A-scan
// classified (column_classification.hpp); then, over the whole volume's mask, the instruments'
// tips and their distances to the segmented ILM and RPE.
#pragma once

#include <memory>
#include <string_view>

#include "ioct/gpu/cuda/backend.hpp"  // Backend, BackendUnavailable
#include "ioct/gpu/instruments/instrument_config.hpp"
#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/gpu/instruments/tip_finder.hpp"
#include "ioct/gpu/segmentation/segmenter.hpp"  // BscanSpan
#include "ioct/gpu/segmentation/surfaces.hpp"
#include "ioct/gpu/volume/volume.hpp"
#include "ioct/gpu/volume/volume_ref.hpp"

namespace ioct::gpu::instruments {

using segmentation::BscanSpan;

class InstrumentDetector {
 public:
  virtual ~InstrumentDetector() = default;

  // B-scans `group` of `volume` are new: classifies their A-scans into `findings` (reset first
  // when its dimensions differ from the volume's), then finds the tips over the whole mask with
  // `surfaces` (the segmentation of the same volume; empty or of other dimensions: no distances).
  // Throws std::out_of_range for a group outside the volume, std::invalid_argument for a volume
  // of no depth. The CUDA detection reads a device ref in place, after the work on its stream
  // (the live stages' device volume: no B-scan crosses the bus); the CPU one takes host refs
  // only (std::invalid_argument for a device ref).
  void detect_group(VolumeRef volume, BscanSpan group, const segmentation::Surfaces& surfaces,
                    InstrumentFindings& findings);
  void detect_group(const Volume& volume, BscanSpan group, const segmentation::Surfaces& surfaces,
                    InstrumentFindings& findings) {
    detect_group(VolumeRef::on_host(volume), group, surfaces, findings);
  }

  // detect_group in steps, for a caller with work of its own meanwhile (the live stages filter
  // and segment while the classes come): begin_group checks the group and starts its
  // classification (the CUDA detection enqueues it on its own stream, after the work the volume's
  // stream has so far, and returns; the CPU one classifies before it returns), end_group takes
  // the classes into the same `findings` and finds the tips, or after locate_tips() only their
  // distances. In between, `findings` is not to be read nor the
  // group's B-scans written, and `findings` must outlive the group. A begin_group while one is
  // pending ends that one first (no tips); end_group with none pending, or for other findings,
  // throws std::logic_error. drop_group() ends a pending group without tips (its classes in its
  // findings, its tips and any earlier group's cleared), waiting for the device to be done with
  // the volume: for a caller unwinding.
  //
  // locate_tips() may come in between: it takes the classes and finds the tips from the mask
  // alone (TipFinder::locate), so that end_group() is left with the distances, which need the
  // surfaces (the live stages locate while the device segments). Without it end_group() does
  // both; after it, `findings` hold the tips without distances until end_group().
  void begin_group(VolumeRef volume, BscanSpan group, InstrumentFindings& findings);
  void locate_tips(InstrumentFindings& findings);
  void end_group(const segmentation::Surfaces& surfaces, InstrumentFindings& findings);
  void drop_group();

  // Every B-scan of `volume`.
  void detect_volume(const Volume& volume, const segmentation::Surfaces& surfaces,
                     InstrumentFindings& findings);

  const InstrumentConfig& config() const noexcept { return config_; }
  const VolumeSampling& sampling() const noexcept { return sampling_; }
  virtual std::string_view backend_name() const noexcept = 0;

 protected:
  InstrumentDetector(const InstrumentConfig& config, const VolumeSampling& sampling);
  // The classification of B-scans `group` into findings.mask, reflex_px and floor (sized).
  // The CUDA detection may return with the classification enqueued; collect() then waits for it
  // and writes it into the same findings (the CPU one has nothing to collect).
  virtual void classify(VolumeRef volume, BscanSpan group, const ColumnParams& params,
                        InstrumentFindings& findings) = 0;
  virtual void collect(InstrumentFindings& findings) { (void)findings; }

 private:
  InstrumentConfig config_;
  VolumeSampling sampling_;
  // Throws std::logic_error naming `call` unless `findings` are the pending group's.
  void check_pending(const InstrumentFindings& findings, const char* call) const;

  TipFinder tip_finder_;  // its buffers serve every group
  // The group under way: begun (classes pending), or its tips located (ended but for their
  // distances).
  InstrumentFindings* pending_ = nullptr;
  bool located_ = false;
};

// Validates both. Backend::automatic takes CUDA where the build and the machine have it;
// Backend::cuda throws BackendUnavailable without it.
std::unique_ptr<InstrumentDetector> make_instrument_detector(Backend backend,
                                                             const InstrumentConfig& config,
                                                             const VolumeSampling& sampling,
                                                             unsigned cpu_threads);

}  // namespace ioct::gpu::instruments
