// Every config refuses values out of range with a message that names the key and the value.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/hal/digitizer_config.hpp"
#include "ioct/hal/raster_scan.hpp"
#include "ioct/sim/simulated_digitizer.hpp"
#include "ioct/sim/simulation_config.hpp"

namespace ioct {
namespace {

struct BadValue {
  std::string key;    // must appear in the message
  std::string value;  // as the message shows it
  std::function<void()> validate;
};

void expect_refused(const BadValue& bad) {
  SCOPED_TRACE(bad.key + " = " + bad.value);
  try {
    bad.validate();
    ADD_FAILURE() << "accepted";
  } catch (const ioct::ConfigError& e) {
    const std::string message = e.what();
    EXPECT_EQ(e.key(), bad.key);
    EXPECT_EQ(e.value(), bad.value);
    EXPECT_EQ(message.rfind(bad.key + " = " + bad.value + ": ", 0), 0u) << message;
    EXPECT_GT(message.size(), bad.key.size() + bad.value.size() + 8) << "says what is allowed";
  }
}

std::function<void()> digitizer_with(std::function<void(hal::DigitizerConfig&)> change) {
  return [change] {
    hal::DigitizerConfig config;
    change(config);
    config.validate();
  };
}

std::function<void()> simulation_with(std::function<void(sim::SimulationConfig&)> change) {
  return [change] {
    sim::SimulationConfig config;
    change(config);
    config.validate();
  };
}

TEST(ConfigValidation, DefaultsAreValid) {
  EXPECT_NO_THROW(hal::DigitizerConfig{}.validate());
  EXPECT_NO_THROW(hal::RasterScan{}.validate());
  EXPECT_NO_THROW(sim::SimulationConfig{}.validate());
}

TEST(ConfigValidation, DigitizerRefusesValuesOutOfRange) {
  const BadValue cases[] = {
      {"digitizer.samples_per_ascan", "8",
       digitizer_with([](auto& c) { c.samples_per_ascan = 8; })},
      {"digitizer.samples_per_ascan", "1377",
       digitizer_with([](auto& c) { c.samples_per_ascan = 1377; })},
      {"digitizer.ascans_per_bscan", "0", digitizer_with([](auto& c) { c.ascans_per_bscan = 0; })},
      {"digitizer.bscans_per_group", "0", digitizer_with([](auto& c) { c.bscans_per_group = 0; })},
      {"digitizer.flyback_sweeps", "100000",
       digitizer_with([](auto& c) { c.flyback_sweeps = 100000; })},
      {"digitizer.ascan_rate_hz", "0", digitizer_with([](auto& c) { c.ascan_rate_hz = 0.0; })},
      {"digitizer.ascan_rate_hz", "nan",
       digitizer_with([](auto& c) { c.ascan_rate_hz = std::numeric_limits<double>::quiet_NaN(); })},
      {"digitizer.sample_bits", "17", digitizer_with([](auto& c) { c.sample_bits = 17; })},
      {"digitizer.clock_source", "7",
       digitizer_with([](auto& c) { c.clock_source = static_cast<hal::ClockSource>(7); })},
      {"digitizer.samples_per_group", "8589934592", digitizer_with([](auto& c) {
         c.samples_per_ascan = 16384;
         c.ascans_per_bscan = 65536;
         c.bscans_per_group = 8;
       })},
  };
  for (const BadValue& bad : cases) expect_refused(bad);
}

TEST(ConfigValidation, SimulationRefusesValuesOutOfRange) {
  const BadValue cases[] = {
      {"source.center_wavelength_nm", "100",
       simulation_with([](auto& c) { c.source.center_wavelength_nm = 100.0; })},
      {"source.envelope_fwhm_nm", "1",
       simulation_with([](auto& c) { c.source.envelope_fwhm_nm = 1.0; })},
      {"detector.read_noise_counts", "-1",
       simulation_with([](auto& c) { c.detector.read_noise_counts = -1.0; })},
      {"retina.speckle_contrast", "2",
       simulation_with([](auto& c) { c.retina.speckle_contrast = 2.0; })},
      {"retina.tissue_index", "inf", simulation_with([](auto& c) {
         c.retina.tissue_index = std::numeric_limits<double>::infinity();
       })},
      {"scan.bscans_per_volume", "0",
       simulation_with([](auto& c) { c.scan.bscans_per_volume = 0; })},
      {"scan.extent_x", "1.5", simulation_with([](auto& c) { c.scan.extent_x = 1.5f; })},
      {"scan.extent_y", "0.5", simulation_with([](auto& c) {
         c.scan.center_y = 0.75f;
         c.scan.extent_y = 0.5f;
       })},
      {"interferometer.dispersion_c2", "nan", simulation_with([](auto& c) {
         c.interferometer.dispersion_c2 = std::numeric_limits<double>::quiet_NaN();
       })},
      {"source.rolloff_6db_depth_mm", "-1",
       simulation_with([](auto& c) { c.source.rolloff_6db_depth_mm = -1.0; })},
      {"source.super_gaussian_order", "0.5", simulation_with([](auto& c) {
         c.source.shape = sim::SpectralShape::super_gaussian;
         c.source.super_gaussian_order = 0.5;
       })},
      {"source.tabulated[1].wavelength_nm", "1000", simulation_with([](auto& c) {
         c.source.shape = sim::SpectralShape::tabulated;
         c.source.tabulated = {{1050.0, 1.0}, {1000.0, 0.5}};
       })},
      {"detector.sweep_power_jitter", "0.5",
       simulation_with([](auto& c) { c.detector.sweep_power_jitter = 0.5; })},
      {"retina.macular_hole.radius_mm", "0", simulation_with([](auto& c) {
         c.retina.macular_hole.enabled = true;
         c.retina.macular_hole.radius_mm = 0.0;
       })},
      {"retina.membrane.thickness_um", "0", simulation_with([](auto& c) {
         c.retina.membrane.enabled = true;
         c.retina.membrane.thickness_um = 0.0;
       })},
      {"retina.disc.cup_radius_mm", "1", simulation_with([](auto& c) {
         c.retina.disc.enabled = true;
         c.retina.disc.cup_radius_mm = 1.0;  // wider than the disc
       })},
      {"retina.disc.cup_depth_um", "-5", simulation_with([](auto& c) {
         c.retina.disc.enabled = true;
         c.retina.disc.cup_depth_um = -5.0;
       })},
      {"anterior.chamber_depth_mm", "0.2", simulation_with([](auto& c) {
         c.preset = sim::SamplePreset::anterior_segment;
         c.anterior.chamber_depth_mm = 0.2;
       })},
      {"mirror.depth_fraction", "1.5", simulation_with([](auto& c) {
         c.preset = sim::SamplePreset::mirror;
         c.mirror.depth_fraction = 1.5;
       })},
      {"instruments[1].pose.pitch_deg", "95", simulation_with([](auto& c) {
         c.instruments.resize(2);
         c.instruments[1].pose.pitch_deg = 95.0f;
       })},
      {"simulation.instruments", "5 instruments",
       simulation_with([](auto& c) { c.instruments.resize(5); })},
      {"simulation.speckle_grain_um", "0",
       simulation_with([](auto& c) { c.speckle_grain_um = 0.0; })},
      {"bench.mirrors.damping", "0",
       simulation_with([](auto& c) { c.bench.mirrors.damping = 0.0; })},
  };
  for (const BadValue& bad : cases) expect_refused(bad);
}

TEST(ConfigValidation, SimulatedDigitizerRefusesWhatItCannotSimulate) {
  const auto prepare_with = [](std::function<void(hal::DigitizerConfig&)> change) {
    return [change] {
      sim::SimulatedDigitizer digitizer{sim::SimulationConfig{}};
      hal::DigitizerConfig config;
      change(config);
      digitizer.prepare(config);
    };
  };
  expect_refused({"digitizer.samples_per_ascan", "8194",
                  prepare_with([](auto& c) { c.samples_per_ascan = 8194; })});
  expect_refused(
      {"scan.ascans_per_bscan", "512", prepare_with([](auto& c) { c.ascans_per_bscan = 256; })});
  // The simulation config is checked when the digitizer is made.
  sim::SimulationConfig bad;
  bad.retina.foveal_pit_depth = -0.5;
  expect_refused({"retina.foveal_pit_depth", "-0.5", [bad] { sim::SimulatedDigitizer{bad}; }});
}

TEST(ConfigValidation, OnlyTheChosenPresetsConfigIsChecked) {
  sim::SimulationConfig config;
  config.anterior.chamber_depth_mm = -1.0;  // not used by the retina preset
  EXPECT_NO_THROW(config.validate());
  config.preset = sim::SamplePreset::anterior_segment;
  EXPECT_THROW(config.validate(), ioct::ConfigError);
}

TEST(ConfigValidation, AFailedPrepareLeavesTheDigitizerUnprepared) {
  sim::SimulatedDigitizer digitizer{sim::SimulationConfig{}};
  hal::DigitizerConfig config;
  digitizer.prepare(config);
  config.samples_per_ascan = 8194;
  EXPECT_THROW(digitizer.prepare(config), ioct::ConfigError);
  EXPECT_EQ(digitizer.state(), hal::Digitizer::State::idle);
  EXPECT_THROW(digitizer.start(), std::logic_error);
}

}  // namespace
}  // namespace ioct
