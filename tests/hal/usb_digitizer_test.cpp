// UsbDigitizer against the emulated instrument under umockdev: configuration as control
// transfers, records streaming through libusb's asynchronous bulk transfers into slots, and
// every fault the digitizer reports (dropped records, flags, a stall of the trigger, an endpoint
// halt, a bad header, unplug and replug, the usbfs memory limit).
#include "ioct/hal/usb/usb_digitizer.hpp"

#include <gtest/gtest.h>
#include <libusb.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <vector>

#include "ioct/common/config_error.hpp"
#include "ioct/hal/usb/usb_error.hpp"
#include "ioct/test_support/allocation_counter.hpp"
#include "usb_test_support.hpp"

namespace ioct::hal::usb::test {
namespace {

using Clock = std::chrono::steady_clock;

class UsbDigitizerTest : public EmulatedInstrumentTest {
 protected:
  void SetUp() override {
    EmulatedInstrumentTest::SetUp();
    if (IsSkipped()) return;
    instrument_ = UsbInstrument::open(small_transfers());
    digitizer_ = std::make_unique<UsbDigitizer>(instrument_);
  }
  void TearDown() override {
    digitizer_.reset();
    instrument_.reset();
  }

  std::vector<std::uint16_t> acquire(GroupInfo& info) {
    std::vector<std::uint16_t> group(digitizer_->config().samples_per_group() + 8, 0xFFFF);
    digitizer_->acquire_group(group, info);
    // Nothing beyond the group is touched.
    for (std::size_t i = digitizer_->config().samples_per_group(); i < group.size(); ++i) {
      EXPECT_EQ(group[i], 0xFFFF) << "word " << i << " past the group was written";
    }
    group.resize(digitizer_->config().samples_per_group());
    return group;
  }

  std::shared_ptr<UsbInstrument> instrument_;
  std::unique_ptr<UsbDigitizer> digitizer_;
};

TEST_F(UsbDigitizerTest, PrepareSendsEverySettingAndReadsItBack) {
  DigitizerConfig config = small_geometry();
  config.clock_source = ClockSource::internal;
  config.trigger.source = TriggerSource::software;
  config.trigger.level_volts = -0.25;
  config.trigger.delay_samples = 12;
  config.ascan_rate_hz = 200'000.0;
  digitizer_->prepare(config);

  using protocol::Param;
  const std::map<Param, std::uint32_t> expected = {
      {Param::samples_per_ascan, 64},
      {Param::ascans_per_bscan, 16},
      {Param::flyback_sweeps, 4},
      {Param::clock_source, 1},
      {Param::sweep_rate_hz, 200'000},
      {Param::trigger_source, 1},
      {Param::trigger_level_mv, static_cast<std::uint32_t>(-250)},
      {Param::trigger_delay_samples, 12},
  };
  EXPECT_EQ(emulator().params(), expected);
  // Each setting was read back after being set.
  std::map<std::uint16_t, int> sets, gets;
  for (const ControlRequest& r : emulator().control_log()) {
    if (r.setup.request == static_cast<std::uint8_t>(protocol::Request::set_param)) {
      ++sets[r.setup.value];
    }
    if (r.setup.request == static_cast<std::uint8_t>(protocol::Request::get_param)) {
      EXPECT_EQ(sets[r.setup.value], 1) << "GET_PARAM " << r.setup.value << " before its SET";
      ++gets[r.setup.value];
    }
  }
  EXPECT_EQ(sets.size(), expected.size());
  EXPECT_EQ(gets.size(), expected.size());
  EXPECT_FALSE(emulator().acquiring());  // prepare() does not start anything
}

TEST_F(UsbDigitizerTest, SettingTheInstrumentDoesNotTakeIsAnError) {
  emulator().override_param(protocol::Param::flyback_sweeps, 2);
  try {
    digitizer_->prepare(small_geometry());
    FAIL() << "prepare() accepted a setting the instrument reads back differently";
  } catch (const UsbError& e) {
    EXPECT_NE(std::string(e.what()).find("did not take digitizer.flyback_sweeps"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("reads back 2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(digitizer_->state(), Digitizer::State::idle);
}

TEST_F(UsbDigitizerTest, GeometryBeyondTheInstrumentIsAConfigError) {
  const auto key_of = [&](const DigitizerConfig& config) {
    try {
      digitizer_->prepare(config);
    } catch (const ConfigError& e) {
      return e.key();
    }
    return std::string("(accepted)");
  };
  DigitizerConfig config = small_geometry();
  config.samples_per_ascan = 8192;  // the instrument records at most 4096
  EXPECT_EQ(key_of(config), "digitizer.samples_per_ascan");
  config = small_geometry();
  config.sample_bits = 14;  // its ADC has 12
  EXPECT_EQ(key_of(config), "digitizer.sample_bits");
}

TEST_F(UsbDigitizerTest, StartArmsAndStartsStopStops) {
  digitizer_->prepare(small_geometry());
  const std::size_t before = emulator().requests().size();
  digitizer_->start();
  std::vector<protocol::Request> requests = emulator().requests();
  ASSERT_EQ(requests.size(), before + 2);
  EXPECT_EQ(requests[before], protocol::Request::acq_arm);
  EXPECT_EQ(requests[before + 1], protocol::Request::acq_start);
  EXPECT_TRUE(emulator().acquiring());
  digitizer_->stop();
  requests = emulator().requests();
  EXPECT_EQ(requests.back(), protocol::Request::acq_stop);
  EXPECT_FALSE(emulator().acquiring());
}

TEST_F(UsbDigitizerTest, RecordsLandInTheSlotSampleForSample) {
  const DigitizerConfig config = small_geometry();
  digitizer_->prepare(config);
  EXPECT_EQ(digitizer_->plan().parts_per_record, 3u);  // header + two 1024-byte bodies
  digitizer_->start();
  const std::uint64_t sweeps_per_group = config.sweeps_per_group();
  for (std::uint64_t g = 0; g < 12; ++g) {
    GroupInfo info;
    const std::vector<std::uint16_t> group = acquire(info);
    ASSERT_EQ(info.status, 0u) << "group " << g;
    EXPECT_EQ(info.first_sweep_counter, g * sweeps_per_group);
    EXPECT_EQ(info.missed_sweeps, 0u);
    ASSERT_TRUE(group_matches(group, config, info.first_sweep_counter)) << "group " << g;
  }
  const RecordCounters counters = digitizer_->counters();
  EXPECT_EQ(counters.groups, 12u);
  EXPECT_EQ(counters.faulty_groups, 0u);
  EXPECT_EQ(counters.records, 48u);
  const std::uint64_t payload = 12 * config.samples_per_group() * 2;
  EXPECT_EQ(counters.direct_bytes + counters.staged_bytes, payload);
  // Both paths ran: body transfers of a group whose slot was already handed over land in it
  // directly; those queued before acquire_group() handed it over come through staging.
  EXPECT_GT(counters.direct_bytes, 0u);
  EXPECT_GT(counters.staged_bytes, 0u);
  // Never more than the configured transfers in flight.
  EXPECT_LE(emulator().bulk_in_bytes_in_flight_peak(),
            std::uint64_t{small_transfers().transfers_in_flight} * 1024u);
}

TEST_F(UsbDigitizerTest, PayloadEndingMidPacketIsCopiedFromTheTailTransfer) {
  DigitizerConfig config = small_geometry();
  config.samples_per_ascan = 40;
  config.ascans_per_bscan = 10;  // 800 bytes: one packet straight in, 288 bytes copied
  digitizer_->prepare(config);
  EXPECT_EQ(digitizer_->plan().tail_copy_bytes, 288u);
  digitizer_->start();
  for (std::uint64_t g = 0; g < 4; ++g) {
    GroupInfo info;
    const std::vector<std::uint16_t> group = acquire(info);
    ASSERT_EQ(info.status, 0u);
    ASSERT_TRUE(group_matches(group, config, g * config.sweeps_per_group())) << "group " << g;
  }
}

TEST_F(UsbDigitizerTest, AcquireGroupAllocatesNothingOnceStreaming) {
  const DigitizerConfig config = small_geometry();
  digitizer_->prepare(config);
  digitizer_->start();
  std::vector<std::uint16_t> group(config.samples_per_group());
  GroupInfo info;
  digitizer_->acquire_group(group, info);
  test_support::AllocationCounter counter;
  for (int g = 0; g < 8; ++g) {
    digitizer_->acquire_group(group, info);
    ASSERT_EQ(info.status, 0u);
  }
  EXPECT_EQ(counter.allocations(), 0u)
      << "counted by " << test_support::allocation_counting_method();
}

TEST_F(UsbDigitizerTest, DroppedRecordsAreMissedSweepsAndOverrun) {
  const DigitizerConfig config = small_geometry();
  const std::uint64_t spb = config.sweeps_per_bscan();
  emulator().drop_records(5, 2);  // records 5 and 6 never leave the instrument
  digitizer_->prepare(config);
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  ASSERT_EQ(info.status, 0u);
  std::vector<std::uint16_t> group = acquire(info);
  EXPECT_EQ(info.first_sweep_counter, 4 * spb);
  EXPECT_EQ(info.missed_sweeps, 2 * spb);
  EXPECT_EQ(info.status, kGroupOverrun);
  EXPECT_TRUE(group_matches(group, config, {4 * spb, 7 * spb, 8 * spb, 9 * spb}));
  group = acquire(info);
  EXPECT_EQ(info.first_sweep_counter, 10 * spb);
  EXPECT_EQ(info.missed_sweeps, 0u);
  EXPECT_EQ(info.status, 0u);
  EXPECT_TRUE(group_matches(group, config, 10 * spb));
}

TEST_F(UsbDigitizerTest, RecordFlagsBecomeGroupFlags) {
  emulator().flag_record(6, protocol::kRecordClockFault, 0);
  emulator().flag_record(9, 0, 3);  // three sweep triggers missing
  digitizer_->prepare(small_geometry());
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  EXPECT_EQ(info.status, 0u);
  acquire(info);
  EXPECT_EQ(info.status, kGroupClockFault);
  acquire(info);
  EXPECT_EQ(info.status, kGroupMissedTriggers);
  acquire(info);
  EXPECT_EQ(info.status, 0u);
}

TEST_F(UsbDigitizerTest, StalledTriggerTimesOutThenTheStreamRestarts) {
  const DigitizerConfig config = small_geometry();  // timeout_ms = 300
  const std::uint64_t spb = config.sweeps_per_bscan();
  emulator().stall_after_records(8);
  digitizer_->prepare(config);
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  acquire(info);
  ASSERT_EQ(info.status, 0u);

  const auto started = Clock::now();
  acquire(info);
  const auto waited = Clock::now() - started;
  EXPECT_EQ(info.status, kGroupTimeout);
  EXPECT_EQ(info.first_sweep_counter, 8 * spb);  // where the group should have begun
  EXPECT_GE(waited, std::chrono::milliseconds(300));
  EXPECT_LT(waited, std::chrono::milliseconds(2000));
  EXPECT_EQ(digitizer_->last_fault(), RecordFault::timeout);
  EXPECT_NE(digitizer_->describe_last_fault().find("digitizer.timeout_ms"), std::string::npos);

  // Triggers are back: the records lost while restarting are missed sweeps.
  emulator().stall_after_records(std::nullopt);
  const std::vector<std::uint16_t> group = acquire(info);
  const std::uint64_t gap = emulator().options().restart_gap_records;
  EXPECT_EQ(info.status, 0u);
  EXPECT_EQ(info.first_sweep_counter, (8 + gap) * spb);
  EXPECT_EQ(info.missed_sweeps, gap * spb);
  EXPECT_TRUE(group_matches(group, config, info.first_sweep_counter));
  EXPECT_EQ(digitizer_->counters().resyncs, 1u);

  // In between, the stream was stopped, the endpoint reset and the stream started again.
  const std::vector<protocol::Request> requests = emulator().requests();
  ASSERT_GE(requests.size(), 2u);
  EXPECT_EQ(requests[requests.size() - 2], protocol::Request::acq_stop);
  EXPECT_EQ(requests.back(), protocol::Request::acq_start);
  EXPECT_EQ(emulator().clear_halts(protocol::kRecordEndpoint), 1u);
}

TEST_F(UsbDigitizerTest, HaltedEndpointIsClearedAndTheStreamRestarts) {
  const DigitizerConfig config = small_geometry();
  digitizer_->prepare(config);
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  ASSERT_EQ(info.status, 0u);
  emulator().halt_record_endpoint();
  // The halt hits whichever transfer is reaped next: the group in progress or the one after.
  int faulty = 0;
  for (int g = 0; g < 3 && faulty == 0; ++g) {
    acquire(info);
    if (info.status != 0) {
      ++faulty;
      EXPECT_EQ(info.status, kGroupOverrun);
      EXPECT_EQ(digitizer_->last_fault(), RecordFault::transfer_failed);
      EXPECT_NE(digitizer_->describe_last_fault().find("LIBUSB_TRANSFER_STALL"), std::string::npos)
          << digitizer_->describe_last_fault();
    }
  }
  ASSERT_EQ(faulty, 1);
  // Records flow again only once the halt is cleared.
  const std::vector<std::uint16_t> group = acquire(info);
  EXPECT_EQ(info.status, 0u);
  EXPECT_GT(info.missed_sweeps, 0u);
  EXPECT_TRUE(group_matches(group, config, info.first_sweep_counter));
  EXPECT_EQ(emulator().clear_halts(protocol::kRecordEndpoint), 1u);
}

TEST_F(UsbDigitizerTest, MalformedHeaderIsABadRecordAndTheStreamRecovers) {
  const DigitizerConfig config = small_geometry();
  emulator().corrupt_record(6);
  digitizer_->prepare(config);
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  ASSERT_EQ(info.status, 0u);
  acquire(info);
  EXPECT_EQ(info.status, kGroupOverrun);
  EXPECT_EQ(digitizer_->last_fault(), RecordFault::bad_record);
  const std::vector<std::uint16_t> group = acquire(info);
  EXPECT_EQ(info.status, 0u);
  EXPECT_TRUE(group_matches(group, config, info.first_sweep_counter));
}

TEST_F(UsbDigitizerTest, UnplugMidStreamIsDeviceLostAndReplugReconnects) {
  DigitizerConfig config = small_geometry();
  // The loss must be reported as such, not as a stall: give the stall timeout room beyond the
  // testbed's own latency (its uevent delivery holds up the ioctl emulation for a few hundred
  // ms under ThreadSanitizer).
  config.timeout_ms = 3000;
  digitizer_->prepare(config);
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  ASSERT_EQ(info.status, 0u);

  emulator().unplug();
  const auto started = Clock::now();
  acquire(info);
  EXPECT_EQ(info.status & kGroupDeviceLost, kGroupDeviceLost)
      << digitizer_->describe_last_fault() << "; after "
      << std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - started).count()
      << " ms; instrument lost: " << instrument_->device_lost();
  EXPECT_LT(Clock::now() - started, std::chrono::milliseconds(2500));
  EXPECT_TRUE(instrument_->device_lost());
  EXPECT_EQ(digitizer_->last_fault(), RecordFault::device_lost);
  const auto again = Clock::now();
  acquire(info);  // at once, every time, until restarted
  EXPECT_EQ(info.status, kGroupDeviceLost);
  EXPECT_LT(Clock::now() - again, std::chrono::milliseconds(100));
  digitizer_->stop();
  EXPECT_THROW(digitizer_->start(), UsbError);  // not back yet

  emulator().replug();
  ASSERT_TRUE(wait_until([&] { return instrument_->arrivals() >= 1; }, std::chrono::seconds(3)))
      << "no hotplug arrival";
  ASSERT_TRUE(emulator().params().empty());  // the replugged instrument forgot its settings
  digitizer_->start();                       // re-enumerates, reopens, sends them again
  EXPECT_FALSE(instrument_->device_lost());
  EXPECT_EQ(emulator().params().at(protocol::Param::samples_per_ascan), 64u);
  const std::vector<std::uint16_t> group = acquire(info);
  EXPECT_EQ(info.status, 0u);
  EXPECT_EQ(info.first_sweep_counter, 0u);  // armed again
  EXPECT_TRUE(group_matches(group, config, 0));
}

TEST_F(UsbDigitizerTest, UsbfsMemoryLimitIsNamedWithItsValue) {
  const std::filesystem::path limit =
      std::filesystem::path(emulator().sys_dir()) / "module/usbcore/parameters/usbfs_memory_mb";
  std::filesystem::create_directories(limit.parent_path());
  std::ofstream(limit) << "16\n";
  emulator().limit_urb_bytes(3 * 1024);  // room for 3 of the 6 transfers
  digitizer_->prepare(small_geometry());
  try {
    digitizer_->start();
    FAIL() << "start() queued transfers beyond the usbfs limit";
  } catch (const UsbError& e) {
    const std::string text = e.what();
    EXPECT_EQ(e.libusb_code(), LIBUSB_ERROR_NO_MEM) << text;
    EXPECT_NE(text.find("/sys/module/usbcore/parameters/usbfs_memory_mb is 16 MiB"),
              std::string::npos)
        << text;
    // Header transfers are one 512-byte packet: 512 + 1024 + 1024 + 512 bytes fit, the next
    // 1024 do not.
    EXPECT_NE(text.find("failed after 4"), std::string::npos) << text;
    EXPECT_NE(text.find("6.0 KiB of USB transfers in flight"), std::string::npos) << text;
    EXPECT_NE(text.find("usb.transfers_in_flight"), std::string::npos) << text;
  }
  EXPECT_EQ(digitizer_->state(), Digitizer::State::prepared);
  emulator().limit_urb_bytes(0);
  digitizer_->start();
  GroupInfo info;
  acquire(info);
  EXPECT_EQ(info.status, 0u);
}

TEST_F(UsbDigitizerTest, StopAndStartAgainBeginsAtCounterZero) {
  const DigitizerConfig config = small_geometry();
  digitizer_->prepare(config);
  for (int run = 0; run < 3; ++run) {
    digitizer_->start();
    GroupInfo info;
    for (std::uint64_t g = 0; g < 2; ++g) {
      const std::vector<std::uint16_t> group = acquire(info);
      ASSERT_EQ(info.status, 0u) << "run " << run;
      EXPECT_EQ(info.first_sweep_counter, g * config.sweeps_per_group());
      EXPECT_TRUE(group_matches(group, config, info.first_sweep_counter));
    }
    digitizer_->stop();
  }
}

}  // namespace
}  // namespace ioct::hal::usb::test
