// What the USB tests share: a fixture that brings up the emulated instrument (or skips, saying
// why), small geometries, and a check of a group's samples against the emulated ADC.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "emulated_instrument.hpp"
#include "ioct/hal/digitizer_config.hpp"
#include "ioct/hal/usb/usb_instrument_config.hpp"

namespace ioct::hal::usb::test {

// 64 samples x 16 A-scans (+4 flyback) x 4 B-scans: each B-scan is 2048 bytes, four 512-byte
// packets, read as a header and two 1024-byte body transfers.
DigitizerConfig small_geometry();
// Few, small transfers so that a group needs several rounds of resubmission.
UsbInstrumentConfig small_transfers();

// Waits until `condition` holds, at most `limit`.
bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds limit);

// Every sample of every B-scan of `group` is what the emulated ADC recorded, B-scan b having
// started at sweep counter bscan_counters[b].
testing::AssertionResult group_matches(std::span<const std::uint16_t> group,
                                       const DigitizerConfig& config,
                                       const std::vector<std::uint64_t>& bscan_counters,
                                       std::uint16_t adc_bits = 12);
// The same for consecutive B-scans from `first_counter`.
testing::AssertionResult group_matches(std::span<const std::uint16_t> group,
                                       const DigitizerConfig& config, std::uint64_t first_counter);

class EmulatedInstrumentTest : public testing::Test {
 protected:
  void SetUp() override;
  virtual EmulatedInstrument::Options options() const { return {}; }
  EmulatedInstrument& emulator() { return *emulator_; }

 private:
  std::unique_ptr<EmulatedInstrument> emulator_;
};

}  // namespace ioct::hal::usb::test
