#include "ioct/sim/simulated_digitizer.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "ioct/common/config_error.hpp"

namespace ioct::sim {
namespace {

// Independent streams derived from the one seed.
constexpr std::uint64_t kNoiseTableStream = 0x6E6F6973'65746162;   // "noisetab"
constexpr std::uint64_t kNoiseOffsetStream = 0x6E6F6973'656F6666;  // "noiseoff"
constexpr std::uint64_t kSpeckleStream = 0x73706563'6B6C6521;      // "speckle!"

}  // namespace

SimulatedDigitizer::SimulatedDigitizer(const SimulationConfig& simulation)
    : simulation_(simulation) {
  simulation_.validate();
}

void SimulatedDigitizer::do_prepare(const hal::DigitizerConfig& config) {
  if (config.clock_source != hal::ClockSource::external_k_clock) {
    throw ioct::ConfigError("digitizer.clock_source", std::string(to_string(config.clock_source)),
                            "the simulator models a k-clocked source only: use external_k_clock");
  }
  if (config.samples_per_ascan > FringeTables::kMaxSamples) {
    throw ioct::ConfigError("digitizer.samples_per_ascan",
                            ioct::format_value(std::uint64_t{config.samples_per_ascan}),
                            "the simulator supports up to " +
                                ioct::format_value(std::uint64_t{FringeTables::kMaxSamples}));
  }
  if (simulation_.scan.ascans_per_bscan != config.ascans_per_bscan) {
    throw ioct::ConfigError("scan.ascans_per_bscan",
                            ioct::format_value(std::uint64_t{simulation_.scan.ascans_per_bscan}),
                            "must equal digitizer.ascans_per_bscan = " +
                                ioct::format_value(std::uint64_t{config.ascans_per_bscan}));
  }
  synthesizer_.emplace(simulation_.source, simulation_.detector, config.samples_per_ascan,
                       config.sample_bits, splitmix64(simulation_.seed ^ kNoiseTableStream));
  retina_.emplace(simulation_.retina, simulation_.source.axial_pixel_um(),
                  config.samples_per_ascan / 2);
  amplitude_counts_ = static_cast<float>(simulation_.detector.fringe_counts *
                                         DetectorConfig::count_scale(config.sample_bits));
  speckle_key_ = splitmix64(simulation_.seed ^ kSpeckleStream);
}

void SimulatedDigitizer::do_start() {
  noise_offsets_.reseed(simulation_.seed ^ kNoiseOffsetStream);
  sweep_counter_ = 0;
}

float SimulatedDigitizer::speckle(std::size_t interface, std::uint32_t bscan_in_volume,
                                  std::uint32_t ascan) const noexcept {
  const double contrast = simulation_.retina.speckle_contrast;
  if (contrast == 0.0) return 1.0f;
  const std::uint64_t position =
      (std::uint64_t{interface} << 56) | (std::uint64_t{bscan_in_volume} << 28) | ascan;
  const double u = unit_open_zero(splitmix64(speckle_key_ ^ position));
  // Rayleigh-distributed amplitude with mean 1: the brightness of fully developed speckle.
  const double rayleigh = std::sqrt(-std::log(u)) * (2.0 / std::sqrt(std::numbers::pi));
  return static_cast<float>((1.0 - contrast) + contrast * rayleigh);
}

std::size_t SimulatedDigitizer::gather_reflectors(std::uint32_t bscan_in_volume,
                                                  std::uint32_t ascan) noexcept {
  const RetinaColumn column = retina_->column(simulation_.scan.position(bscan_in_volume, ascan));
  const FringeTables& fringes = synthesizer_->fringes();
  std::size_t count = 0;
  for (std::size_t i = 0; i < column.size(); ++i) {
    if (!fringes.drawable(column[i].depth_px) || column[i].reflectivity <= 0.0f) continue;
    reflectors_[count++] = {
        FringeTables::resolve(column[i].depth_px),
        amplitude_counts_ * column[i].reflectivity * speckle(i, bscan_in_volume, ascan)};
  }
  return count;
}

void SimulatedDigitizer::do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) {
  const hal::DigitizerConfig& geometry = config();
  const std::uint64_t sweeps_per_bscan = geometry.sweeps_per_bscan();
  const std::uint64_t first_bscan = sweep_counter_ / sweeps_per_bscan;
  std::uint16_t* out = group.data();
  for (std::uint32_t b = 0; b < geometry.bscans_per_group; ++b) {
    const std::uint32_t line = simulation_.scan.bscan_in_volume(first_bscan + b);
    for (std::uint32_t a = 0; a < geometry.ascans_per_bscan; ++a) {
      const std::size_t reflectors = gather_reflectors(line, a);
      const std::uint32_t noise_a = noise_offsets_.below(SpectrumSynthesizer::kNoiseOffsets);
      const std::uint32_t noise_b = noise_offsets_.below(SpectrumSynthesizer::kNoiseOffsets);
      synthesizer_->synthesize(std::span<const Reflector>(reflectors_.data(), reflectors), noise_a,
                               noise_b, out);
      out += geometry.samples_per_ascan;
    }
  }
  info.first_sweep_counter = sweep_counter_;
  info.missed_sweeps = 0;
  info.status = 0;
  sweep_counter_ += geometry.sweeps_per_group();
}

LayerTruth SimulatedDigitizer::truth_at(std::uint32_t bscan_in_volume, std::uint32_t ascan) const {
  const RetinaColumn column = retina().column(simulation_.scan.position(bscan_in_volume, ascan));
  const FringeTables& fringes = synthesizer_->fringes();
  const auto drawn = [&](RetinalInterface interface) {
    const float depth = column[static_cast<std::size_t>(interface)].depth_px;
    return fringes.drawable(depth) ? FringeTables::depth_px(FringeTables::resolve(depth))
                                   : std::numeric_limits<float>::quiet_NaN();
  };
  return {drawn(RetinalInterface::ilm), drawn(RetinalInterface::rpe)};
}

const RetinaModel& SimulatedDigitizer::retina() const {
  if (!retina_) throw std::logic_error("simulated digitizer: prepare() first");
  return *retina_;
}

}  // namespace ioct::sim
