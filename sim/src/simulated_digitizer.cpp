#include "ioct/sim/simulated_digitizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#include "ioct/common/config_error.hpp"
#include "ioct/concurrency/monotonic_clock.hpp"
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
// How often the acquisition thread looks whether the workers have finished a late group.
constexpr std::uint64_t kLatePollNs = 100'000;

// MurmurHash3's finaliser: a bijection that spreads neighbouring sweep numbers over all bits
// and keeps 0 at 0, so the first B-scan after start() has the stream the seed always gave it.
constexpr std::uint64_t bscan_stream_key(std::uint64_t first_sweep) noexcept {
  std::uint64_t x = first_sweep;
  x = (x ^ (x >> 33)) * 0xFF51AFD7ED558CCDull;
  x = (x ^ (x >> 33)) * 0xC4CEB93FE53E03B5ull;
  return x ^ (x >> 33);
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
  // The old workers go first: they use what is about to be replaced.
  pipeline_.reset();
  // Everything is built before anything is replaced: a failed prepare leaves no half state.
  SynthesisSetup setup;
  setup.source = simulation_.source;
  setup.interferometer = simulation_.interferometer;
  setup.detector = simulation_.detector;
  setup.clock = config.clock_source;
  setup.samples = config.samples_per_ascan;
  setup.sample_bits = config.sample_bits;
  setup.seed = simulation_.seed;
  const std::uint32_t depth_bins = config.samples_per_ascan / 2;
  auto model = make_model(simulation_, depth_bins);
  const auto make_context = [&] {
    SynthesisContext context;
    context.synthesizer = std::make_unique<SpectrumSynthesizer>(setup);
    context.instruments.reserve(simulation_.instruments.size());
    for (const InstrumentConfig& tool : simulation_.instruments) {
      context.instruments.emplace_back(tool, model->field_half_width_mm(),
                                       simulation_.source.axial_pixel_um(), depth_bins);
    }
    return context;
  };
  const auto tools = static_cast<std::uint32_t>(simulation_.instruments.size());
  const auto make_job = [&](bool with_samples) {
    GroupJob job;
    job.positions.resize(config.sweeps_per_group());
    job.poses.resize(std::size_t{config.bscans_per_group} * tools);
    job.truth.resize(config.ascans_per_bscan, config.bscans_per_group, tools);
    // Written here, so that the pages are resident before the acquisition thread copies them.
    if (with_samples) job.samples.assign(config.samples_per_group(), 0);
    return job;
  };
  SynthesisContext inline_context = make_context();
  std::vector<SynthesisContext> contexts;
  std::vector<GroupJob> ahead;
  if (simulation_.workers > 0) {
    for (std::uint32_t w = 0; w < simulation_.workers; ++w) contexts.push_back(make_context());
    for (int j = 0; j < 2; ++j) ahead.push_back(make_job(true));
  }
  GroupJob current = make_job(false);
  GroupTruth truth;
  truth.resize(config.ascans_per_bscan, config.bscans_per_group, tools);

  model_ = std::move(model);
  inline_ = std::move(inline_context);
  contexts_ = std::move(contexts);
  ahead_ = std::move(ahead);
  current_ = std::move(current);
  truth_ = std::move(truth);
  late_groups_.store(0, std::memory_order_relaxed);
  speckle_key_ = splitmix64(simulation_.seed ^ kSpeckleStream);
  bench_->scanner().set_dynamics(bench_->config().mirrors, config.ascan_rate_hz);
  if (simulation_.workers > 0) start_pipeline(config);
}

void SimulatedDigitizer::start_pipeline(const hal::DigitizerConfig& config) {
  pipeline_ = std::make_unique<SynthesisPipeline>(
      simulation_.workers, static_cast<std::uint32_t>(ahead_.size()), config.bscans_per_group,
      [this](std::uint32_t worker, std::uint32_t slot, std::uint32_t bscan) {
        GroupJob& job = ahead_[slot];
        const hal::DigitizerConfig& geometry = this->config();
        const std::size_t per_bscan =
            std::size_t{geometry.ascans_per_bscan} * geometry.samples_per_ascan;
        synthesize_bscan(contexts_[worker], job, bscan, job.samples.data() + bscan * per_bscan,
                         job.truth);
      },
      simulation_.worker_priority);
}

void SimulatedDigitizer::do_start() {
  if (bench_->faults().active(Fault::usb_disconnect)) {
    throw std::runtime_error(
        "simulated digitizer: start(): the USB device is not connected (usb_disconnect)");
  }
  sweep_counter_ = 0;
  groups_ = 0;
  pending_missed_ = 0;
  pending_status_ = 0;
  backlog_sweeps_ = 0;
  device_lost_ = false;
  start_ns_ = ioct::monotonic_ns();
  if (pipeline_) {
    // Work of the previous run still running finishes before its slots are rewritten.
    pipeline_->cancel();
    while (!pipeline_->idle()) std::this_thread::sleep_for(std::chrono::microseconds(100));
    delivered_ = 0;
    take_bench_state(ahead_[0]);
    if (ahead_[0].has_records) pipeline_->dispatch(0);
  }
}

void SimulatedDigitizer::do_stop() noexcept {
  if (pipeline_) pipeline_->cancel();
}

void SimulatedDigitizer::require_prepared() const {
  if (!inline_.synthesizer) throw std::logic_error("simulated digitizer: prepare() first");
}

hal::BeamPosition SimulatedDigitizer::raster_position(std::uint64_t sweep) const noexcept {
  const std::uint64_t per_line = config().sweeps_per_bscan();
  const std::uint64_t bscan = sweep / per_line;
  const auto within = static_cast<std::uint32_t>(sweep % per_line);
  const std::uint32_t line = simulation_.scan.bscan_in_volume(bscan);
  // Flyback sweeps are not recorded; they rest at the line's end.
  return simulation_.scan.position(line, std::min(within, config().ascans_per_bscan - 1));
}

void SimulatedDigitizer::place_beam(std::uint64_t sweeps, hal::BeamPosition* positions) noexcept {
  if (bench_->galvo_attached()) {
    bench_->scanner().advance(sweeps, true, positions);
    return;
  }
  for (std::uint64_t s = 0; s < sweeps; ++s) positions[s] = raster_position(sweep_counter_ + s);
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
  const std::uint64_t start = ioct::monotonic_ns();
  const std::uint64_t timeout_ns = std::uint64_t{config().timeout_ms} * 1'000'000ull;
  for (;;) {
    const std::uint64_t now = ioct::monotonic_ns();
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

void SimulatedDigitizer::draw_instruments(SynthesisContext& context, hal::BeamPosition beam,
                                          std::uint64_t key, float& tool_px) const noexcept {
  tool_px = kNaN;
  ToolHit first;
  for (const InstrumentModel& tool : context.instruments) {
    const ToolHit hit = tool.hit(beam);
    if (hit.hit && (!first.hit || hit.entry_px < first.entry_px)) first = hit;
  }
  if (!first.hit) return;
  DepthProfile& profile = context.synthesizer->profile();
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

void SimulatedDigitizer::take_bench_state(GroupJob& job) {
  const hal::DigitizerConfig& geometry = config();
  FaultInjector& faults = bench_->faults();
  const std::uint32_t mask = faults.active_mask();
  const auto on = [mask](Fault fault) { return (mask & FaultInjector::bit(fault)) != 0; };
  job.has_records = false;

  // Unplugged: nothing more until the device is back and the digitizer restarted.
  if (device_lost_ || on(Fault::usb_disconnect)) {
    device_lost_ = true;
    job.info = {sweep_counter_, 0, hal::kGroupDeviceLost};
    return;
  }
  // No records at all: the stall timeout fires.
  std::uint32_t blocking = FaultInjector::bit(Fault::digitizer_stall);
  if (geometry.trigger.source == hal::TriggerSource::sweep_input) {
    blocking |= FaultInjector::bit(Fault::trigger_loss);
  }
  if ((mask & blocking) != 0 && wait_out(mask & blocking)) {
    job.info = {sweep_counter_, 0, hal::kGroupTimeout};
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
  job.sampling = clock_lost ? SweepSampling::time_linear : SweepSampling::configured;
  job.light = bench_->light_on_sample();

  job.info.first_sweep_counter = sweep_counter_;
  job.info.missed_sweeps = static_cast<std::uint32_t>(
      std::min<std::uint64_t>(pending_missed_, std::numeric_limits<std::uint32_t>::max()));
  job.info.status = status;
  pending_missed_ = 0;
  pending_status_ = 0;

  place_beam(geometry.sweeps_per_group(), job.positions.data());
  job.truth.group_index = groups_;
  job.truth.first_sweep_counter = sweep_counter_;
  const std::uint64_t sweeps_per_bscan = geometry.sweeps_per_bscan();
  const std::size_t tools = inline_.instruments.size();
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    const std::uint64_t first_sweep = sweep_counter_ + b * sweeps_per_bscan;
    const double seconds = static_cast<double>(first_sweep) / geometry.ascan_rate_hz;
    for (std::size_t t = 0; t < tools; ++t) {
      const ToolPose pose = inline_.instruments[t].pose_at(seconds);
      job.poses[b * tools + t] = pose;
      // The tip the detection must find (open forceps: between the jaws' ends), as the
      // instrument accuracy tests take it.
      job.truth.tool_states[b * tools + t] = inline_.instruments[t].tip_state(pose);
    }
  }
  sweep_counter_ += geometry.sweeps_per_group();
  ++groups_;
  job.has_records = true;
}

void SimulatedDigitizer::synthesize_bscan(SynthesisContext& context, const GroupJob& job,
                                          std::uint32_t bscan, std::uint16_t* out,
                                          GroupTruth& truth) const noexcept {
  const hal::DigitizerConfig& geometry = config();
  const std::uint64_t sweeps_per_bscan = geometry.sweeps_per_bscan();
  SpectrumSynthesizer& synthesizer = *context.synthesizer;
  synthesizer.select(job.sampling);
  const std::size_t tools = context.instruments.size();
  for (std::size_t t = 0; t < tools; ++t) {
    context.instruments[t].place(job.poses[bscan * tools + t]);
  }
  // The B-scan's own noise stream, named by its first sweep: whichever thread draws it, and in
  // whatever order, the same B-scan gets the same noise.
  const std::uint64_t first_sweep = job.info.first_sweep_counter + bscan * sweeps_per_bscan;
  Xoshiro256 noise((simulation_.seed ^ kNoiseOffsetStream) ^ bscan_stream_key(first_sweep));
  DepthProfile& profile = synthesizer.profile();
  const double field_mm = model_->field_half_width_mm();
  for (std::uint32_t a = 0; a < geometry.ascans_per_bscan; ++a) {
    const hal::BeamPosition beam = job.positions[bscan * sweeps_per_bscan + a];
    const std::size_t record = std::size_t{bscan} * geometry.ascans_per_bscan + a;
    const std::uint64_t key =
        lateral_key(speckle_key_, beam, field_mm, simulation_.speckle_grain_um);
    profile.begin_column(key);
    float tool_px = kNaN;
    if (tools != 0) draw_instruments(context, beam, key, tool_px);
    const ColumnTruth column = model_->draw(beam, key, profile);
    synthesizer.synthesize(synthesizer.sweep_noise(noise.next()), job.light, out);
    out += geometry.samples_per_ascan;
    truth.ilm_px[record] = column.ilm_px;
    truth.rpe_px[record] = column.rpe_px;
    truth.tool_px[record] = tool_px;
    truth.beam_x[record] = beam.x;
    truth.beam_y[record] = beam.y;
  }
}

namespace {

void copy_truth(const GroupTruth& from, GroupTruth& to) noexcept {
  to.group_index = from.group_index;
  to.first_sweep_counter = from.first_sweep_counter;
  std::copy(from.ilm_px.begin(), from.ilm_px.end(), to.ilm_px.begin());
  std::copy(from.rpe_px.begin(), from.rpe_px.end(), to.rpe_px.begin());
  std::copy(from.tool_px.begin(), from.tool_px.end(), to.tool_px.begin());
  std::copy(from.beam_x.begin(), from.beam_x.end(), to.beam_x.begin());
  std::copy(from.beam_y.begin(), from.beam_y.end(), to.beam_y.begin());
  std::copy(from.tool_states.begin(), from.tool_states.end(), to.tool_states.begin());
}

void sleep_ns(std::uint64_t ns) noexcept {
  timespec ts{static_cast<time_t>(ns / 1'000'000'000ull), static_cast<long>(ns % 1'000'000'000ull)};
  ::clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, nullptr);
}

}  // namespace

std::uint64_t SimulatedDigitizer::group_end_ns(const hal::GroupInfo& info) const noexcept {
  const double period_ns = 1e9 / config().ascan_rate_hz;
  const auto end_sweep =
      static_cast<double>(info.first_sweep_counter + config().sweeps_per_group());
  return start_ns_ + static_cast<std::uint64_t>(end_sweep * period_ns);
}

void SimulatedDigitizer::deliver_ahead(std::span<std::uint16_t> group, hal::GroupInfo& info) {
  const auto count = static_cast<std::uint32_t>(ahead_.size());
  // The group after this one first, so the workers have it while this one is copied out. Its
  // slot held the group delivered last time.
  const auto next_slot = static_cast<std::uint32_t>((delivered_ + 1) % count);
  take_bench_state(ahead_[next_slot]);
  if (ahead_[next_slot].has_records) pipeline_->dispatch(next_slot);

  const auto slot = static_cast<std::uint32_t>(delivered_ % count);
  ++delivered_;
  GroupJob& job = ahead_[slot];
  info = job.info;
  if (!job.has_records) return;  // a timeout or a lost device: the payload is untouched
  // Polls, never blocks on the workers: a DMA engine that has not filled the buffer yet. Late
  // when the workers finished it after its last sweep ended (whenever this is called).
  while (!pipeline_->ready(slot)) sleep_ns(kLatePollNs);
  const bool late = pipeline_->finished_ns(slot) > group_end_ns(job.info);
  std::copy(job.samples.begin(), job.samples.end(), group.begin());
  copy_truth(job.truth, truth_);
  if (late) {
    info.status |= hal::kGroupLate;
    late_groups_.fetch_add(1, std::memory_order_relaxed);
  }
}

void SimulatedDigitizer::do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) {
  if (pipeline_) {
    deliver_ahead(group, info);
    return;
  }
  take_bench_state(current_);
  info = current_.info;
  if (!current_.has_records) return;
  const hal::DigitizerConfig& geometry = config();
  const std::size_t per_bscan = std::size_t{geometry.ascans_per_bscan} * geometry.samples_per_ascan;
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    synthesize_bscan(inline_, current_, b, group.data() + b * per_bscan, current_.truth);
  }
  copy_truth(current_.truth, truth_);
}

LayerTruth SimulatedDigitizer::truth_at(std::uint32_t bscan_in_volume, std::uint32_t ascan) const {
  require_prepared();
  const ColumnTruth column = model_->layers(simulation_.scan.position(bscan_in_volume, ascan));
  const DepthProfile& profile = inline_.synthesizer->profile();
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
  return inline_.synthesizer->sampling();
}

const std::vector<InstrumentModel>& SimulatedDigitizer::instruments() const {
  require_prepared();
  return inline_.instruments;
}

}  // namespace ioct::sim
