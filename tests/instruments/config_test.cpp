// The config's refusals name the key and the value.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "ioct/common/config_error.hpp"
#include "ioct/gpu/instruments/instrument_config.hpp"
#include "ioct/gpu/instruments/instrument_detector.hpp"

namespace ioct::gpu::instruments {
namespace {

void expect_refused(const std::function<void(InstrumentConfig&)>& change, const std::string& key) {
  InstrumentConfig config;
  change(config);
  try {
    config.validate();
    FAIL() << key << " accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
}

TEST(InstrumentConfig, DefaultsAreValid) {
  EXPECT_NO_THROW(InstrumentConfig{}.validate());
}

TEST(InstrumentConfig, BadValuesAreRefusedNamingTheKey) {
  expect_refused([](InstrumentConfig& c) { c.object_margin = 0; }, "instruments.object_margin");
  expect_refused([](InstrumentConfig& c) { c.dark_margin = 40; }, "instruments.dark_margin");
  expect_refused([](InstrumentConfig& c) { c.gap_um = 0.0; }, "instruments.gap_um");
  expect_refused([](InstrumentConfig& c) { c.max_reflex_um = -1.0; }, "instruments.max_reflex_um");
  expect_refused([](InstrumentConfig& c) { c.min_shadow_um = 1e9; }, "instruments.min_shadow_um");
  expect_refused([](InstrumentConfig& c) { c.partial_gap_um = 0.0; }, "instruments.partial_gap_um");
  expect_refused([](InstrumentConfig& c) { c.min_ascans = 0; }, "instruments.min_ascans");
  expect_refused([](InstrumentConfig& c) { c.medium_group_index = 0.5; },
                 "instruments.medium_group_index");
  expect_refused([](InstrumentConfig& c) { c.warn_rpe_um = -5.0; }, "instruments.warn_rpe_um");
  expect_refused([](InstrumentConfig& c) { c.warn_rpe_um = std::nan(""); },
                 "instruments.warn_rpe_um");
}

TEST(InstrumentConfig, TheDetectorRefusesABadSampling) {
  VolumeSampling sampling;
  sampling.axial_um_per_px = 0.0;
  EXPECT_THROW(make_instrument_detector(Backend::cpu, {}, sampling, 1), ConfigError);
}

}  // namespace
}  // namespace ioct::gpu::instruments
