// GpiodLines: its config is validated, a chip or line it cannot have is named, and the safety
// calls are harmless before prepare(). Against a GPIO chip emulated under umockdev (this
// machine's kernel has none) it requests, drives, reads back and waits for edges through the
// real libgpiod. With a GPIO chip named in IOCT_TEST_GPIO_CHIP (a gpio-sim or gpio-mockup chip
// whose lines nothing else uses) it also drives and reads back real lines.
#include "ioct/hal/gpio/gpiod_lines.hpp"

#include <gtest/gtest.h>
#include <linux/gpio.h>
#include <time.h>

#include <chrono>
#include <cstdlib>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "emulated_gpio_chip.hpp"
#include "ioct/common/config_error.hpp"

namespace ioct::hal::gpio {
namespace {

std::string prepare_error(const LinesConfig& config) {
  GpiodLines lines;
  try {
    lines.prepare(config);
  } catch (const ConfigError& e) {
    return std::string("ConfigError: ") + e.what();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(prepared)";
}

TEST(GpiodLines, TwoLinesOnOneOffsetIsAConfigErrorNamingBoth) {
  LinesConfig config;
  config.footswitch.offset = config.laser_emission.offset;
  const std::string error = prepare_error(config);
  EXPECT_EQ(error.rfind("ConfigError: lines.footswitch.offset = 0", 0), 0u) << error;
  EXPECT_NE(error.find("lines.laser_emission.offset"), std::string::npos) << error;
}

TEST(GpiodLines, EmptyChipIsAConfigError) {
  LinesConfig config;
  config.chip.clear();
  EXPECT_EQ(prepare_error(config).rfind("ConfigError: lines.chip", 0), 0u);
}

TEST(GpiodLines, MissingChipIsNamedWithTheChipsThisMachineHas) {
  LinesConfig config;
  config.chip = "ioct-no-such-gpio-chip";
  const std::string error = prepare_error(config);
  EXPECT_EQ(error.rfind("lines.chip = \"ioct-no-such-gpio-chip\": cannot open this GPIO chip", 0),
            0u)
      << error;
  EXPECT_NE(error.find(describe_gpio_chips()), std::string::npos) << error;
}

TEST(GpiodLines, DeviceThatIsNoGpioChipIsRefused) {
  LinesConfig config;
  config.chip = "/dev/null";
  const std::string error = prepare_error(config);
  EXPECT_EQ(error.rfind("lines.chip = \"/dev/null\": cannot open this GPIO chip", 0), 0u) << error;
}

TEST(GpiodLines, SafetyCallsAreHarmlessBeforePrepare) {
  GpiodLines lines;
  EXPECT_FALSE(lines.prepared());
  lines.set_laser_emission(true);
  EXPECT_FALSE(lines.laser_emission());
  EXPECT_EQ(lines.read_inputs(), LineInputs{});
  lines.toggle_watchdog();
  lines.release();
  EXPECT_EQ(lines.line_errors(), 0u);
  EXPECT_THROW(lines.wait_event(std::chrono::milliseconds(1)), std::logic_error);
  EXPECT_EQ(lines.backend(), "gpiod");
}

TEST(GpiodLines, DrivesAndReadsBackLinesOnARealChip) {
  const char* chip = std::getenv("IOCT_TEST_GPIO_CHIP");
  if (chip == nullptr || *chip == '\0') {
    GTEST_SKIP() << "no GPIO chip to test on: set IOCT_TEST_GPIO_CHIP to a gpio-sim or "
                    "gpio-mockup chip with at least 6 free lines; "
                 << describe_gpio_chips();
  }
  LinesConfig config;
  config.chip = chip;
  config.consumer = "ioct-hal-test";
  GpiodLines lines;
  lines.prepare(config);
  EXPECT_FALSE(lines.laser_emission());  // requested inactive
  lines.set_laser_emission(true);
  EXPECT_TRUE(lines.laser_emission());
  lines.set_laser_emission(false);
  EXPECT_FALSE(lines.laser_emission());
  lines.toggle_watchdog();
  lines.toggle_watchdog();
  EXPECT_EQ(lines.line_errors(), 0u);
  EXPECT_FALSE(lines.wait_event(std::chrono::milliseconds(10)).has_value());
  // Requesting the same lines twice: the second owner is told who holds them.
  GpiodLines second;
  try {
    second.prepare(config);
    FAIL() << "the lines were requested twice";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("held by \"ioct-hal-test\""), std::string::npos)
        << e.what();
  }
}

std::uint64_t clock_ns(clockid_t clock) {
  timespec now{};
  clock_gettime(clock, &now);
  return static_cast<std::uint64_t>(now.tv_sec) * 1'000'000'000u +
         static_cast<std::uint64_t>(now.tv_nsec);
}

bool eventually(const std::function<bool()>& condition) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

// The default wiring: emission 0, watchdog 1, laser ready 2, sweep trigger 3, k-clock 4,
// footswitch 5 (active low).
class GpiodLinesOnEmulatedChip : public testing::Test {
 protected:
  void SetUp() override {
    chip_ = std::make_unique<test::EmulatedGpioChip>();
    if (!test::EmulatedGpioChip::in_mock_environment()) {
      GTEST_SKIP() << "umockdev is not in effect in this process (libumockdev-preload.so.0 "
                      "could not be preloaded): the emulated GPIO chip cannot be attached";
    }
    config_.chip = "gpiochip0";
    config_.consumer = "ioct-rt-test";
  }
  test::EmulatedGpioChip& chip() { return *chip_; }

  std::unique_ptr<test::EmulatedGpioChip> chip_;
  LinesConfig config_;
};

TEST_F(GpiodLinesOnEmulatedChip, PrepareRequestsOutputsInactiveAndInputsWithEdgeEvents) {
  GpiodLines lines;
  lines.prepare(config_);
  EXPECT_EQ(lines.chip_description(), "gpiochip0 [ioct-emulated], 8 lines");
  for (unsigned offset = 0; offset < 6; ++offset) {
    EXPECT_TRUE(chip().requested(offset)) << "line " << offset;
    EXPECT_EQ(chip().consumer(offset), "ioct-rt-test");
  }
  EXPECT_FALSE(chip().requested(6));
  EXPECT_EQ(chip().request_flags(0), GPIOHANDLE_REQUEST_OUTPUT);
  EXPECT_EQ(chip().request_flags(1), GPIOHANDLE_REQUEST_OUTPUT);
  EXPECT_EQ(chip().request_flags(2), GPIOHANDLE_REQUEST_INPUT);
  EXPECT_EQ(chip().request_flags(5), GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_ACTIVE_LOW);
  // Outputs start inactive: emission off from the moment the line is ours.
  EXPECT_EQ(chip().output_history(0), std::vector<bool>{false});
  EXPECT_FALSE(lines.laser_emission());
}

TEST_F(GpiodLinesOnEmulatedChip, EmissionIsDrivenAndReadBackFromTheLine) {
  config_.laser_emission.active_low = true;  // wired through an inverting driver
  GpiodLines lines;
  lines.prepare(config_);
  EXPECT_TRUE(chip().physical_level(0));  // inactive = high on an active-low line
  lines.set_laser_emission(true);
  EXPECT_FALSE(chip().physical_level(0));
  EXPECT_TRUE(lines.laser_emission());
  lines.set_laser_emission(false);
  EXPECT_TRUE(chip().physical_level(0));
  EXPECT_FALSE(lines.laser_emission());
  EXPECT_EQ(lines.line_errors(), 0u);
}

TEST_F(GpiodLinesOnEmulatedChip, WatchdogToggles) {
  GpiodLines lines;
  lines.prepare(config_);
  for (int i = 0; i < 3; ++i) lines.toggle_watchdog();
  EXPECT_EQ(chip().output_history(1), (std::vector<bool>{false, true, false, true}));
}

TEST_F(GpiodLinesOnEmulatedChip, InputsReadLogicalLevels) {
  GpiodLines lines;
  lines.prepare(config_);
  chip().drive(5, true, 0);  // footswitch released: active low, the line idles high
  EXPECT_EQ(lines.read_inputs(), LineInputs{});
  chip().drive(2, true, 0);
  chip().drive(4, true, 0);
  chip().drive(5, false, 0);  // pressed
  LineInputs expected;
  expected.laser_ready = true;
  expected.k_clock_valid = true;
  expected.footswitch = true;
  EXPECT_EQ(lines.read_inputs(), expected);
}

TEST_F(GpiodLinesOnEmulatedChip, EdgesComeInTheOrderTheyHappenedWithKernelTimestamps) {
  chip().drive(5, true, 0);  // footswitch released (active low: the line idles high)
  GpiodLines lines;
  lines.prepare(config_);
  const std::uint64_t now = clock_ns(CLOCK_MONOTONIC);
  chip().drive(4, true, now + 2000);   // k-clock valid, stamped later ...
  chip().drive(2, true, now + 1000);   // ... than laser ready, which is queued second
  chip().drive(5, false, now + 3000);  // footswitch pressed: a rising edge of an active-low line
  const auto first = lines.wait_event(std::chrono::milliseconds(500));
  const auto second = lines.wait_event(std::chrono::milliseconds(500));
  const auto third = lines.wait_event(std::chrono::milliseconds(500));
  ASSERT_TRUE(first && second && third) << (first ? to_string(first->line) : "none") << " "
                                        << (second ? to_string(second->line) : "none") << " "
                                        << (third ? to_string(third->line) : "none");
  EXPECT_EQ(first->line, InputLine::laser_ready);
  EXPECT_EQ(first->timestamp_ns, now + 1000);
  EXPECT_EQ(second->line, InputLine::k_clock_valid);
  EXPECT_EQ(second->timestamp_ns, now + 2000);
  EXPECT_EQ(third->line, InputLine::footswitch);
  EXPECT_TRUE(first->rising && second->rising && third->rising);
  chip().drive(2, false, now + 4000);
  const auto falling = lines.wait_event(std::chrono::milliseconds(500));
  ASSERT_TRUE(falling);
  EXPECT_EQ(falling->line, InputLine::laser_ready);
  EXPECT_FALSE(falling->rising);

  const auto started = std::chrono::steady_clock::now();
  EXPECT_FALSE(lines.wait_event(std::chrono::milliseconds(30)).has_value());
  EXPECT_GE(std::chrono::steady_clock::now() - started, std::chrono::milliseconds(25));
}

TEST_F(GpiodLinesOnEmulatedChip, RealtimeStampsOfOldKernelsAreMovedOntoTheMonotonicClock) {
  GpiodLines lines;
  lines.prepare(config_);
  chip().drive(3, true, clock_ns(CLOCK_REALTIME));  // what kernels before 5.7 stamp
  const auto event = lines.wait_event(std::chrono::milliseconds(500));
  ASSERT_TRUE(event);
  const std::uint64_t monotonic = clock_ns(CLOCK_MONOTONIC);
  EXPECT_LE(event->timestamp_ns, monotonic);
  EXPECT_GT(event->timestamp_ns + 1'000'000'000u, monotonic);
}

TEST_F(GpiodLinesOnEmulatedChip, LineHeldByAnotherConsumerNamesItsHolder) {
  chip().hold(3, "other-daemon");
  const std::string error = prepare_error(config_);
  EXPECT_EQ(error.rfind("lines.sweep_trigger_present.offset = 3 on gpiochip0 [ioct-emulated], "
                        "8 lines: cannot request the line",
                        0),
            0u)
      << error;
  EXPECT_NE(error.find("held by \"other-daemon\""), std::string::npos) << error;
  // Nothing stays requested after the failure.
  EXPECT_TRUE(eventually([&] { return !chip().requested(0) && !chip().requested(2); }));
}

TEST_F(GpiodLinesOnEmulatedChip, OffsetBeyondTheChipIsNamed) {
  config_.footswitch.offset = 12;
  const std::string error = prepare_error(config_);
  EXPECT_EQ(error,
            "lines.footswitch.offset = 12 on gpiochip0 [ioct-emulated], 8 lines: the chip "
            "has lines 0..7");
}

TEST_F(GpiodLinesOnEmulatedChip, SecondOwnerIsToldWhoHoldsTheLines) {
  GpiodLines first;
  first.prepare(config_);
  const std::string error = prepare_error(config_);
  EXPECT_NE(error.find("lines.laser_emission.offset = 0"), std::string::npos) << error;
  EXPECT_NE(error.find("held by \"ioct-rt-test\""), std::string::npos) << error;
}

TEST_F(GpiodLinesOnEmulatedChip, ReleaseTurnsEmissionOffFirstAndFreesTheLines) {
  GpiodLines lines;
  lines.prepare(config_);
  lines.set_laser_emission(true);
  lines.release();
  EXPECT_FALSE(lines.prepared());
  EXPECT_EQ(chip().output_history(0), (std::vector<bool>{false, true, false}));
  EXPECT_TRUE(eventually([&] {
    for (unsigned offset = 0; offset < 6; ++offset) {
      if (chip().requested(offset)) return false;
    }
    return true;
  }));
  lines.prepare(config_);  // and they can be had again
  EXPECT_TRUE(chip().requested(0));
}

}  // namespace
}  // namespace ioct::hal::gpio
