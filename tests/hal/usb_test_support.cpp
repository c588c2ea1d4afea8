#include "usb_test_support.hpp"

#include <thread>

namespace ioct::hal::usb::test {

DigitizerConfig small_geometry() {
  DigitizerConfig config;
  config.samples_per_ascan = 64;
  config.ascans_per_bscan = 16;
  config.flyback_sweeps = 4;
  config.bscans_per_group = 4;
  config.sample_bits = 12;
  config.timeout_ms = 300;
  return config;
}

UsbInstrumentConfig small_transfers() {
  UsbInstrumentConfig config;
  config.transfers_in_flight = 6;
  config.transfer_bytes = 1024;
  config.staging_buffers = 8;
  config.galvo_transfers_in_flight = 2;
  config.galvo_transfer_bytes = 1024;
  config.control_timeout_ms = 1000;
  return config;
}

bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= deadline) return condition();
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

testing::AssertionResult group_matches(std::span<const std::uint16_t> group,
                                       const DigitizerConfig& config,
                                       const std::vector<std::uint64_t>& bscan_counters,
                                       std::uint16_t adc_bits) {
  if (bscan_counters.size() != config.bscans_per_group) {
    return testing::AssertionFailure() << "test error: " << bscan_counters.size()
                                       << " counters for " << config.bscans_per_group << " B-scans";
  }
  std::size_t i = 0;
  for (std::uint32_t b = 0; b < config.bscans_per_group; ++b) {
    for (std::uint32_t a = 0; a < config.ascans_per_bscan; ++a) {
      for (std::uint32_t s = 0; s < config.samples_per_ascan; ++s, ++i) {
        const std::uint16_t expected = emulated_sample(bscan_counters[b] + a, s, adc_bits);
        if (group[i] != expected) {
          return testing::AssertionFailure()
                 << "B-scan " << b << " (sweep " << bscan_counters[b] << ") A-scan " << a
                 << " sample " << s << ": " << group[i] << ", the instrument recorded " << expected;
        }
      }
    }
  }
  return testing::AssertionSuccess();
}

testing::AssertionResult group_matches(std::span<const std::uint16_t> group,
                                       const DigitizerConfig& config, std::uint64_t first_counter) {
  std::vector<std::uint64_t> counters;
  for (std::uint32_t b = 0; b < config.bscans_per_group; ++b) {
    counters.push_back(first_counter + b * config.sweeps_per_bscan());
  }
  return group_matches(group, config, counters);
}

void EmulatedInstrumentTest::SetUp() {
  emulator_ = std::make_unique<EmulatedInstrument>(options());
  if (!EmulatedInstrument::in_mock_environment()) {
    GTEST_SKIP() << "umockdev is not in effect in this process (libumockdev-preload.so.0 could "
                    "not be preloaded, e.g. umockdev is not installed): the emulated USB "
                    "instrument cannot be attached";
  }
}

}  // namespace ioct::hal::usb::test
