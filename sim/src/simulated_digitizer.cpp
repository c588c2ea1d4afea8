#include "ioct/sim/simulated_digitizer.hpp"

#include <time.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#include "ioct/common/config_error.hpp"
#include "ioct/sim/anterior_segment_model.hpp"
#include "ioct/sim/mirror_model.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/speckle.hpp"

namespace ioct::sim {
namespace {

// Independent streams derived from the one seed.
constexpr std::uint64_t kNoiseOffsetStream = 0x6E6F6973'656F6666;  // "noiseoff"
constexpr std::uint64_t kSpeckleStream = 0x73706563'6B6C6521;      // "speckle!"
constexpr std::uint64_t kToolSalt = 0x746F6F6C'73757266;           // "toolsurf"
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

std::uint64_t monotonic_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull +
         static_cast<std::uint64_t>(ts.tv_nsec);
}

std::unique_ptr<SampleModel> make_model(const SimulationConfig& s, std::uint32_t depth_bins) {
  const double axial = s.source.axial_pixel_um();
  switch (s.preset) {
    case SamplePreset::anterior_segment:
      return std::make_unique<AnteriorSegmentModel>(s.anterior, axial, depth_bins);
    case SamplePreset::mirror:
      return std::make_unique<MirrorModel>(s.mirror, axial, s.source.k_min(), depth_bins);
    case SamplePreset::retina:
    default:
      return std::make_unique<RetinaModel>(s.retina, axial, depth_bins);
  }
}

}  // namespace

SimulatedDigitizer::SimulatedDigitizer(const SimulationConfig& simulation,
                                       std::shared_ptr<SimulatedBench> bench)
    : simulation_(simulation), bench_(std::move(bench)) {
  simulation_.validate();
  if (!bench_) bench_ = std::make_shared<SimulatedBench>(simulation_.bench);
}

SimulatedDigitizer::~SimulatedDigitizer() = default;

void SimulatedDigitizer::do_prepare(const hal::DigitizerConfig& config) {
  if (config.samples_per_ascan > SpectrumSynthesizer::kMaxSamples) {
    throw ioct::ConfigError(
        "digitizer.samples_per_ascan", ioct::format_value(std::uint64_t{config.samples_per_ascan}),
        "the simulator supports up to " +
            ioct::format_value(std::uint64_t{SpectrumSynthesizer::kMaxSamples}));
  }
  if (simulation_.scan.ascans_per_bscan != config.ascans_per_bscan) {
    throw ioct::ConfigError("scan.ascans_per_bscan",
                            ioct::format_value(std::uint64_t{simulation_.scan.ascans_per_bscan}),
                            "must equal digitizer.ascans_per_bscan = " +
                                ioct::format_value(std::uint64_t{config.ascans_per_bscan}));
  }
  // Everything is built before anything is replaced: a failed prepare leaves no half state.
  SynthesisSetup setup;
  setup.source = simulation_.source;
  setup.interferometer = simulation_.interferometer;
  setup.detector = simulation_.detector;
  setup.clock = config.clock_source;
  setup.samples = config.samples_per_ascan;
  setup.sample_bits = config.sample_bits;
  setup.seed = simulation_.seed;
  auto synthesizer = std::make_unique<SpectrumSynthesizer>(setup);
  const std::uint32_t depth_bins = config.samples_per_ascan / 2;
  auto model = make_model(simulation_, depth_bins);
  std::vector<InstrumentModel> instruments;
  instruments.reserve(simulation_.instruments.size());
  for (const InstrumentConfig& tool : simulation_.instruments) {
    instruments.emplace_back(tool, model->field_half_width_mm(),
                             simulation_.source.axial_pixel_um(), depth_bins);
  }
  std::vector<hal::BeamPosition> positions(config.sweeps_per_group());
  GroupTruth truth;
  truth.resize(config.ascans_per_bscan, config.bscans_per_group,
               static_cast<std::uint32_t>(instruments.size()));

  synthesizer_ = std::move(synthesizer);
  model_ = std::move(model);
  instruments_ = std::move(instruments);
  positions_ = std::move(positions);
  truth_ = std::move(truth);
  speckle_key_ = splitmix64(simulation_.seed ^ kSpeckleStream);
  bench_->scanner().set_dynamics(bench_->config().mirrors, config.ascan_rate_hz);
}

void SimulatedDigitizer::do_start() {
  if (bench_->faults().active(Fault::usb_disconnect)) {
    throw std::runtime_error(
        "simulated digitizer: start(): the USB device is not connected (usb_disconnect)");
  }
  noise_stream_.reseed(simulation_.seed ^ kNoiseOffsetStream);
  sweep_counter_ = 0;
  groups_ = 0;
  pending_missed_ = 0;
  pending_status_ = 0;
  backlog_sweeps_ = 0;
  device_lost_ = false;
}

void SimulatedDigitizer::require_prepared() const {
  if (!synthesizer_) throw std::logic_error("simulated digitizer: prepare() first");
}

hal::BeamPosition SimulatedDigitizer::raster_position(std::uint64_t sweep) const noexcept {
  const std::uint64_t per_line = config().sweeps_per_bscan();
  const std::uint64_t bscan = sweep / per_line;
  const auto within = static_cast<std::uint32_t>(sweep % per_line);
  const std::uint32_t line = simulation_.scan.bscan_in_volume(bscan);
  // Flyback sweeps are not recorded; they rest at the line's end.
  return simulation_.scan.position(line, std::min(within, config().ascans_per_bscan - 1));
}

void SimulatedDigitizer::place_beam(std::uint64_t sweeps) noexcept {
  if (bench_->galvo_attached()) {
    bench_->scanner().advance(sweeps, true, positions_.data());
    return;
  }
  for (std::uint64_t s = 0; s < sweeps; ++s) positions_[s] = raster_position(sweep_counter_ + s);
}

void SimulatedDigitizer::lose_sweeps(std::uint64_t sweeps, bool triggers,
                                     std::uint32_t status) noexcept {
  if (sweeps == 0) return;
  if (bench_->galvo_attached()) bench_->scanner().advance(sweeps, triggers, nullptr);
  sweep_counter_ += sweeps;
  pending_missed_ += sweeps;
  pending_status_ |= status;
}

bool SimulatedDigitizer::wait_out(std::uint32_t fault_bits) noexcept {
  const std::uint64_t start = monotonic_ns();
  const std::uint64_t timeout_ns = std::uint64_t{config().timeout_ms} * 1'000'000ull;
  for (;;) {
    const std::uint64_t now = monotonic_ns();
    const bool lasting = (bench_->faults().active_mask() & fault_bits) != 0;
    if (!lasting || now - start >= timeout_ns) {
      // The source kept sweeping while nothing was recorded.
      const std::uint64_t elapsed = lasting ? timeout_ns : now - start;
      const auto sweeps = static_cast<std::uint64_t>(
          std::llround(static_cast<double>(elapsed) * 1e-9 * config().ascan_rate_hz));
      const bool trigger_lost = (fault_bits & FaultInjector::bit(Fault::trigger_loss)) != 0;
      lose_sweeps(sweeps, !trigger_lost,
                  trigger_lost ? hal::kGroupMissedTriggers : hal::kGroupOverrun);
      return lasting;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void SimulatedDigitizer::draw_instruments(hal::BeamPosition beam, std::uint64_t key,
                                          float& tool_px) noexcept {
  tool_px = kNaN;
  ToolHit first;
  for (const InstrumentModel& tool : instruments_) {
    const ToolHit hit = tool.hit(beam);
    if (hit.hit && (!first.hit || hit.entry_px < first.entry_px)) first = hit;
  }
  if (!first.hit) return;
  DepthProfile& profile = synthesizer_->profile();
  if (!profile.drawable(first.entry_px)) {
    // Above the axis the tool still shadows what lies below it.
    if (first.entry_px < 0.0f) profile.set_occlusion(0.0f, first.transmission);
    return;
  }
  profile.add_reflector(first.entry_px, first.amplitude, key ^ kToolSalt);
  if (first.exit_px > first.entry_px) {
    profile.add_scatter(first.entry_px, first.exit_px, first.interior_scatter, 0.0f);
    profile.add_reflector(first.exit_px, first.back_amplitude, key ^ (kToolSalt + 1));
  }
  profile.set_occlusion(first.entry_px, first.transmission);
  tool_px = profile.drawn_depth(first.entry_px);
}

void SimulatedDigitizer::do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) {
  const hal::DigitizerConfig& geometry = config();
  FaultInjector& faults = bench_->faults();
  const std::uint32_t mask = faults.active_mask();
  const auto on = [mask](Fault fault) { return (mask & FaultInjector::bit(fault)) != 0; };

  // Unplugged: nothing more until the device is back and the digitizer restarted.
  if (device_lost_ || on(Fault::usb_disconnect)) {
    device_lost_ = true;
    info = {sweep_counter_, 0, hal::kGroupDeviceLost};
    return;
  }
  // No records at all: the stall timeout fires.
  std::uint32_t blocking = FaultInjector::bit(Fault::digitizer_stall);
  if (geometry.trigger.source == hal::TriggerSource::sweep_input) {
    blocking |= FaultInjector::bit(Fault::trigger_loss);
  }
  if ((mask & blocking) != 0 && wait_out(mask & blocking)) {
    info = {sweep_counter_, 0, hal::kGroupTimeout};
    return;
  }
  // The host is slow: records pile up on the board and overflow its memory.
  if (on(Fault::slow_consumer)) {
    const std::uint32_t delay_us = faults.slow_consumer_delay_us();
    std::this_thread::sleep_for(std::chrono::microseconds(delay_us));
    backlog_sweeps_ +=
        static_cast<std::uint64_t>(std::llround(delay_us * 1e-6 * geometry.ascan_rate_hz));
    const std::uint64_t capacity = bench_->config().digitizer_buffer_sweeps;
    if (backlog_sweeps_ > capacity) {
      lose_sweeps(backlog_sweeps_ - capacity, true, hal::kGroupOverrun);
      backlog_sweeps_ = capacity;
    }
  } else {
    backlog_sweeps_ = 0;  // caught up
  }
  lose_sweeps(faults.take_missed_sweeps(), false, hal::kGroupMissedTriggers);

  std::uint32_t status = pending_status_;
  // Without its k-clock an externally clocked digitizer falls back to its own, time-linear clock.
  const bool clock_lost =
      on(Fault::k_clock_dropout) && geometry.clock_source == hal::ClockSource::external_k_clock;
  if (clock_lost) status |= hal::kGroupClockFault;
  synthesizer_->select(clock_lost ? SweepSampling::time_linear : SweepSampling::configured);
  const bool light = bench_->light_on_sample();

  info.first_sweep_counter = sweep_counter_;
  info.missed_sweeps = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(pending_missed_, std::numeric_limits<std::uint32_t>::max()));
  info.status = status;
  pending_missed_ = 0;
  pending_status_ = 0;

  const std::uint64_t sweeps_per_bscan = geometry.sweeps_per_bscan();
  place_beam(geometry.sweeps_per_group());
  truth_.group_index = groups_;
  truth_.first_sweep_counter = sweep_counter_;
  DepthProfile& profile = synthesizer_->profile();
  const double field_mm = model_->field_half_width_mm();
  std::uint16_t* out = group.data();
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    const std::uint64_t first_sweep = sweep_counter_ + b * sweeps_per_bscan;
    const double seconds = static_cast<double>(first_sweep) / geometry.ascan_rate_hz;
    for (std::size_t t = 0; t < instruments_.size(); ++t) {
      const ToolPose pose = instruments_[t].pose_at(seconds);
      instruments_[t].place(pose);
      truth_.tool_states[b * instruments_.size() + t] = instruments_[t].state(pose);
    }
    for (std::uint32_t a = 0; a < geometry.ascans_per_bscan; ++a) {
      const hal::BeamPosition beam = positions_[b * sweeps_per_bscan + a];
      const std::size_t record = std::size_t{b} * geometry.ascans_per_bscan + a;
      const std::uint64_t key =
          lateral_key(speckle_key_, beam, field_mm, simulation_.speckle_grain_um);
      profile.begin_column(key);
      float tool_px = kNaN;
      if (!instruments_.empty()) draw_instruments(beam, key, tool_px);
      const ColumnTruth column = model_->draw(beam, key, profile);
      synthesizer_->synthesize(synthesizer_->sweep_noise(noise_stream_.next()), light, out);
      out += geometry.samples_per_ascan;
      truth_.ilm_px[record] = column.ilm_px;
      truth_.rpe_px[record] = column.rpe_px;
      truth_.tool_px[record] = tool_px;
      truth_.beam_x[record] = beam.x;
      truth_.beam_y[record] = beam.y;
    }
  }
  sweep_counter_ += geometry.sweeps_per_group();
  ++groups_;
}

LayerTruth SimulatedDigitizer::truth_at(std::uint32_t bscan_in_volume, std::uint32_t ascan) const {
  require_prepared();
  const ColumnTruth column = model_->layers(simulation_.scan.position(bscan_in_volume, ascan));
  const DepthProfile& profile = synthesizer_->profile();
  const auto drawn = [&](float depth) {
    return std::isfinite(depth) && profile.drawable(depth) ? profile.drawn_depth(depth) : kNaN;
  };
  return {drawn(column.ilm_px), drawn(column.rpe_px)};
}

const GroupTruth& SimulatedDigitizer::last_group_truth() const {
  require_prepared();
  return truth_;
}

const SampleModel& SimulatedDigitizer::sample_model() const {
  require_prepared();
  return *model_;
}

const SpectralSampling& SimulatedDigitizer::sampling() const {
  require_prepared();
  return synthesizer_->sampling();
}

const std::vector<InstrumentModel>& SimulatedDigitizer::instruments() const {
  require_prepared();
  return instruments_;
}

}  // namespace ioct::sim
