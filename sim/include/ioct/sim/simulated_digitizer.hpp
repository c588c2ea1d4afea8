// The simulator's digitizer: k-clocked spectra of a layered, curved retina, scanned by a raster,
// written straight into the caller's slot memory.
//
// It does not pace itself: acquire_group() returns as soon as the group is computed, and the
// caller keeps the sweep rate (ioct-rt sleeps to each group's deadline). The sweep counter
// advances by every sweep of the group, flyback included, as the hardware's does.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "ioct/hal/digitizer.hpp"
#include "ioct/sim/random.hpp"
#include "ioct/sim/retina_model.hpp"
#include "ioct/sim/simulation_config.hpp"
#include "ioct/sim/spectrum_synthesizer.hpp"

namespace ioct::sim {

// Where the ILM and the RPE were drawn in one A-scan, in px of the processed depth axis
// (samples_per_ascan / 2 bins); NaN when the layer lies outside it.
struct LayerTruth {
  float ilm_px = 0.0f;
  float rpe_px = 0.0f;
};

class SimulatedDigitizer final : public hal::Digitizer {
 public:
  // Throws ioct::ConfigError when `simulation` is invalid.
  explicit SimulatedDigitizer(const SimulationConfig& simulation);

  std::string_view backend() const noexcept override { return "simulated"; }
  const SimulationConfig& simulation() const noexcept { return simulation_; }

  // Ground truth of A-scan `ascan` of line `bscan_in_volume` of the raster: the depths at which
  // the layers are drawn in every volume. Requires prepare(); throws std::logic_error before.
  LayerTruth truth_at(std::uint32_t bscan_in_volume, std::uint32_t ascan) const;
  // The model itself, for other interfaces or positions. Requires prepare().
  const RetinaModel& retina() const;

 protected:
  void do_prepare(const hal::DigitizerConfig& config) override;
  void do_start() override;
  void do_stop() noexcept override {}
  void do_acquire_group(std::span<std::uint16_t> group, hal::GroupInfo& info) override;

 private:
  // Speckle is frozen to the position, as it is for still tissue: the same A-scan of every
  // volume sees the same interface brightness; only the noise differs.
  float speckle(std::size_t interface, std::uint32_t bscan_in_volume,
                std::uint32_t ascan) const noexcept;
  std::size_t gather_reflectors(std::uint32_t bscan_in_volume, std::uint32_t ascan) noexcept;

  SimulationConfig simulation_;
  std::optional<SpectrumSynthesizer> synthesizer_;
  std::optional<RetinaModel> retina_;
  float amplitude_counts_ = 0.0f;  // fringe counts of a reflectivity-1 interface at this ADC
  std::uint64_t speckle_key_ = 0;
  Xoshiro256 noise_offsets_;
  std::uint64_t sweep_counter_ = 0;
  std::array<Reflector, kRetinalInterfaces> reflectors_{};
};

}  // namespace ioct::sim
