// The simulator's digitizer: spectral interferograms of a sample (a layered retina, an anterior
// segment or a calibration mirror, with instruments) as a swept-source OCT records them,
// written straight into the caller's slot memory.
//
// It does not pace itself: acquire_group() returns as soon as the group is computed, and the
// caller keeps the sweep rate (ioct-rt sleeps to each group's deadline).
//
// With simulation.workers = 0 the group is synthesised inside acquire_group(). With workers > 0
// it is synthesised ahead, like a board whose DMA engine fills the host's buffer while the host
// handles the previous group: each acquire_group() takes the bench's state (beam positions from
// the galvo, light, faults) for the group after the one it delivers, hands its B-scans to the
// worker threads, and copies out the group the workers finished meanwhile. So the delivered
// stream is the inline one with the bench state sampled one group earlier; the bytes are the
// same for any worker count. A group the workers have not finished when its last sweep ends is
// waited for (polling, no lock) and delivered whole, flagged hal::kGroupLate: the simulator, not
// the caller, is behind (simulator_late_groups()). The sweep counter
// advances by every sweep of the group, flyback included, as the hardware's does. It is the
// bench's clock: each group advances the shared SimulatedBench by its sweeps, clocking the galvo
// output's samples out and recording each A-scan where the mirrors actually were.
//
// Injected faults (SimulatedBench::faults()) show in GroupInfo as the real digitizer reports
// them; see sim/README.md ("Fault injection"). Stalls and a lost trigger block for the config's
// timeout_ms, as the hardware would.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "ioct/hal/digitizer.hpp"
#include "ioct/recording/recording_format.hpp"
#include "ioct/sim/instrument_model.hpp"
#include "ioct/sim/random.hpp"
#include "ioct/sim/sample_model.hpp"
#include "ioct/sim/simulated_bench.hpp"
#include "ioct/sim/simulation_config.hpp"
#include "ioct/sim/spectrum_synthesizer.hpp"
#include "ioct/sim/synthesis_pipeline.hpp"

namespace ioct::sim {

// Where the ILM and the RPE were drawn in one A-scan, in px of the processed depth axis
// (samples_per_ascan / 2 px); NaN when the layer is absent or outside it.
struct LayerTruth {
  float ilm_px = 0.0f;
  float rpe_px = 0.0f;
};

using GroupTruth = recording::GroupTruth;

class SimulatedDigitizer final : public hal::Digitizer {
 public:
  // Throws ioct::ConfigError when `simulation` is invalid. Without a bench, the digitizer makes
  // its own (simulation.bench): no galvo output, so the beam follows simulation.scan exactly.
  explicit SimulatedDigitizer(const SimulationConfig& simulation,
                              std::shared_ptr<SimulatedBench> bench = nullptr);
  ~SimulatedDigitizer() override;

  std::string_view backend() const noexcept override { return "simulated"; }
  const SimulationConfig& simulation() const noexcept { return simulation_; }
  SimulatedBench& bench() const noexcept { return *bench_; }
  const std::shared_ptr<SimulatedBench>& shared_bench() const noexcept { return bench_; }

  // Ground truth of A-scan `ascan` of line `bscan_in_volume` of simulation.scan, at its
  // commanded position (no galvo lag, no instruments): the depths at which the layers are drawn
  // in every volume. Requires prepare(); throws std::logic_error before.
  LayerTruth truth_at(std::uint32_t bscan_in_volume, std::uint32_t ascan) const;
  // The truth of the group last acquired: per A-scan where the ILM, RPE and an instrument were
  // drawn and where the beam actually was; per B-scan the instruments' poses. Requires prepare().
  const GroupTruth& last_group_truth() const;

  // Requires prepare():
  const SampleModel& sample_model() const;
  // The configured clock's sampling and the calibration that maps it to k (identity for the
  // k-clock); for gpu/'s resampling.
  const SpectralSampling& sampling() const;
  const std::vector<InstrumentModel>& instruments() const;
  // Groups delivered after their last sweep had ended because the workers were behind, since
  // prepare(). Any thread (relaxed).
  std::uint64_t simulator_late_groups() const noexcept {
    return late_groups_.load(std::memory_order_relaxed);
  }
  // Worker threads synthesising ahead (0: inline).
  std::uint32_t workers() const noexcept { return simulation_.workers; }
  // Of those, how many run SCHED_FIFO at simulation.worker_priority (after prepare()).
  std::uint32_t realtime_workers() const noexcept {
    return pipeline_ ? pipeline_->realtime_workers() : 0;
  }
  // Optical path per px of the processed depth axis (um, in air).
  double axial_pixel_um() const noexcept { return simulation_.source.axial_pixel_um(); }

 protected:
  void do_prepare(const hal::DigitizerConfig& config) override;
  // Throws std::runtime_error while the USB device is unplugged (usb_disconnect).
  void do_start() override;
  void do_stop() noexcept override;
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override;

 private:
  // What a B-scan synthesis needs of its own: every worker (and the inline path) has one.
  struct SynthesisContext {
    std::unique_ptr<SpectrumSynthesizer> synthesizer;
    std::vector<InstrumentModel> instruments;
  };
  // One group's bench state, taken on the acquisition thread, and (with workers) its samples.
  struct GroupJob {
    hal::GroupInfo info;
    bool has_records = false;  // false: a timeout or a lost device, nothing to synthesise
    bool light = false;
    SweepSampling sampling = SweepSampling::configured;
    std::vector<hal::BeamPosition> positions;  // one per sweep
    std::vector<ToolPose> poses;               // [bscan][tool]
    GroupTruth truth;
    std::vector<std::uint16_t> samples;  // workers only: the synthesised group
  };

  void require_prepared() const;
  // Everything of a group that depends on the bench's live state (faults, galvo, lines), in
  // sweep order; cheap. May block for a stall's timeout as the hardware would.
  void take_bench_state(GroupJob& job);
  // One B-scan of `job` into `out` (the B-scan's records) and its truth. Depends only on the
  // job and the B-scan's index: the noise stream comes from the seed and its first sweep.
  void synthesize_bscan(SynthesisContext& context, const GroupJob& job, std::uint32_t bscan,
                        std::uint16_t* out, GroupTruth& truth) const noexcept;
  void start_pipeline(const hal::DigitizerConfig& config);
  void deliver_ahead(std::span<std::uint16_t> group, hal::GroupInfo& info);
  std::uint64_t group_end_ns(const hal::GroupInfo& info) const noexcept;
  // Where the beam is at each sweep of the group (galvo or ideal raster).
  void place_beam(std::uint64_t sweeps, hal::BeamPosition* positions) noexcept;
  hal::BeamPosition raster_position(std::uint64_t sweep) const noexcept;
  // Lost sweeps: the bench runs on, nothing is recorded.
  void lose_sweeps(std::uint64_t sweeps, bool triggers, std::uint32_t status) noexcept;
  // Blocks while a stall or lost trigger lasts, at most timeout_ms; true if it still lasts.
  bool wait_out(std::uint32_t fault_bits) noexcept;
  void draw_instruments(SynthesisContext& context, hal::BeamPosition beam, std::uint64_t key,
                        float& tool_px) const noexcept;

  SimulationConfig simulation_;
  std::shared_ptr<SimulatedBench> bench_;
  std::unique_ptr<SampleModel> model_;
  SynthesisContext inline_;                 // the inline path's; its synthesizer answers sampling()
  std::vector<SynthesisContext> contexts_;  // one per worker
  GroupJob current_;                        // inline: the group being acquired
  std::vector<GroupJob> ahead_;             // workers: the group delivered next and the one after
  std::uint64_t delivered_ = 0;             // workers: groups delivered since start()
  std::uint64_t start_ns_ = 0;              // when start() began the sweep clock
  std::atomic<std::uint64_t> late_groups_{0};
  GroupTruth truth_;
  std::uint64_t speckle_key_ = 0;
  std::uint64_t sweep_counter_ = 0;
  std::uint64_t groups_ = 0;
  std::uint64_t pending_missed_ = 0;  // lost since the last group delivered
  std::uint32_t pending_status_ = 0;
  std::uint64_t backlog_sweeps_ = 0;  // how far the host is behind (slow_consumer)
  bool device_lost_ = false;
  // Last: destroyed (its threads joined) before anything they use.
  std::unique_ptr<SynthesisPipeline> pipeline_;
};

}  // namespace ioct::sim
