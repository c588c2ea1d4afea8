// UsbGalvoOutput against the emulated instrument: samples arrive over bulk OUT as int16 pairs
// in order, the status reports drive status(), park() parks at once and drops what is queued.
#include "ioct/hal/usb/usb_galvo_output.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "usb_test_support.hpp"

namespace ioct::hal::usb::test {
namespace {

std::vector<GalvoSample> ramp(std::size_t n) {
  std::vector<GalvoSample> samples(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float t = static_cast<float>(i) / static_cast<float>(n);
    samples[i] = {-1.0f + 2.0f * t, 0.5f - t};
  }
  return samples;
}

std::uint32_t packed(const GalvoSample& s) {
  return static_cast<std::uint16_t>(protocol::galvo_code(s.x)) |
         (static_cast<std::uint32_t>(static_cast<std::uint16_t>(protocol::galvo_code(s.y))) << 16);
}

class UsbGalvoOutputTest : public EmulatedInstrumentTest {
 protected:
  void SetUp() override {
    EmulatedInstrumentTest::SetUp();
    if (IsSkipped()) return;
    instrument_ = UsbInstrument::open(small_transfers());
    galvo_ = std::make_unique<UsbGalvoOutput>(instrument_);
  }
  void TearDown() override {
    galvo_.reset();
    instrument_.reset();
  }
  GalvoOutputConfig config(std::uint32_t capacity = 4096, std::uint32_t lead = 0) {
    GalvoOutputConfig c;
    c.fifo_capacity = capacity;
    c.lead_samples = lead;
    c.park = {-1.0f, 0.5f};
    return c;
  }
  std::size_t write_all(const std::vector<GalvoSample>& samples) {
    std::size_t written = 0;
    while (written < samples.size()) {
      const std::size_t n = galvo_->write(std::span(samples).subspan(written));
      if (n == 0) break;
      written += n;
    }
    return written;
  }

  std::shared_ptr<UsbInstrument> instrument_;
  std::unique_ptr<UsbGalvoOutput> galvo_;
};

TEST_F(UsbGalvoOutputTest, PrepareSetsTheParkPositionAndParks) {
  galvo_->prepare(config());
  const auto params = emulator().params();
  EXPECT_EQ(params.at(protocol::Param::galvo_park_x), 0x8001u);  // -32767 as 16 bits
  EXPECT_EQ(params.at(protocol::Param::galvo_park_y), 16384u);
  EXPECT_EQ(emulator().requests().back(), protocol::Request::galvo_park);
  EXPECT_TRUE(galvo_->status().parked);
}

TEST_F(UsbGalvoOutputTest, SamplesArriveInOrderAsInt16Pairs) {
  galvo_->prepare(config());
  const std::vector<GalvoSample> samples = ramp(3000);
  ASSERT_EQ(write_all(samples), samples.size());  // prefill before start: fits the FIFO
  ASSERT_TRUE(wait_until([&] { return emulator().galvo_received().size() >= samples.size(); },
                         std::chrono::seconds(3)));
  const std::vector<std::uint32_t> received = emulator().galvo_received();
  ASSERT_EQ(received.size(), samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    ASSERT_EQ(received[i], packed(samples[i])) << "sample " << i;
  }
  // The host counts a transfer once libusb has reaped it, a moment after the instrument took it.
  EXPECT_TRUE(wait_until([&] { return galvo_->samples_sent() == samples.size(); },
                         std::chrono::seconds(3)));
  EXPECT_EQ(galvo_->status().samples_written, samples.size());
  EXPECT_EQ(galvo_->status().fifo_fill, samples.size());  // nothing clocked out yet
}

TEST_F(UsbGalvoOutputTest, LeadSamplesAreSkippedAtTheStart) {
  galvo_->prepare(config(4096, 10));
  const std::vector<GalvoSample> samples = ramp(100);
  ASSERT_EQ(write_all(samples), samples.size());
  ASSERT_TRUE(wait_until([&] { return emulator().galvo_received().size() >= 90; },
                         std::chrono::seconds(3)));
  const std::vector<std::uint32_t> received = emulator().galvo_received();
  ASSERT_EQ(received.size(), 90u);
  EXPECT_EQ(received.front(), packed(samples[10]));
  EXPECT_EQ(galvo_->status().fifo_fill, 90u);
}

TEST_F(UsbGalvoOutputTest, WriteTakesNoMoreThanTheFifoHolds) {
  galvo_->prepare(config(256));
  const std::vector<GalvoSample> samples = ramp(1000);
  EXPECT_EQ(galvo_->write(samples), 256u);
  EXPECT_EQ(galvo_->write(samples), 0u);
  EXPECT_EQ(galvo_->status().fifo_fill, 256u);
}

TEST_F(UsbGalvoOutputTest, StartedOutputIsClockedOutAndReported) {
  galvo_->prepare(config());
  ASSERT_EQ(write_all(ramp(2000)), 2000u);
  galvo_->start();
  EXPECT_EQ(emulator().requests().back(), protocol::Request::galvo_start);
  ASSERT_TRUE(
      wait_until([&] { return galvo_->status().samples_output >= 500; }, std::chrono::seconds(3)));
  const GalvoStatus status = galvo_->status();
  EXPECT_FALSE(status.parked);
  EXPECT_EQ(status.samples_written, 2000u);
  EXPECT_EQ(status.fifo_fill, 2000u - status.samples_output);
  EXPECT_EQ(status.faults, 0u);
}

TEST_F(UsbGalvoOutputTest, RunningDryIsAnUnderrun) {
  galvo_->prepare(config());
  galvo_->start();
  ASSERT_TRUE(wait_until([&] { return galvo_->status().underruns > 0; }, std::chrono::seconds(3)));
  EXPECT_EQ(galvo_->status().faults & kGalvoUnderrun, kGalvoUnderrun);
}

TEST_F(UsbGalvoOutputTest, DriverFaultIsReportedAndSticky) {
  galvo_->prepare(config());
  ASSERT_EQ(write_all(ramp(4000)), 4000u);
  galvo_->start();
  emulator().set_galvo_fault(true);
  ASSERT_TRUE(wait_until([&] { return (galvo_->status().faults & kGalvoDriverFault) != 0; },
                         std::chrono::seconds(3)));
  emulator().set_galvo_fault(false);
  EXPECT_TRUE(wait_until(
      [&] { return (instrument_->latest_status().status & protocol::kStatusGalvoFault) == 0; },
      std::chrono::seconds(3)));
  EXPECT_EQ(galvo_->status().faults & kGalvoDriverFault, kGalvoDriverFault);  // sticky
}

TEST_F(UsbGalvoOutputTest, ParkParksAtOnceAndDropsWhatIsQueued) {
  galvo_->prepare(config());
  ASSERT_EQ(write_all(ramp(3000)), 3000u);
  galvo_->start();
  ASSERT_TRUE(wait_until([&] { return emulator().galvo_streaming(); }, std::chrono::seconds(1)));
  const std::size_t before = emulator().requests().size();
  galvo_->park();
  const std::vector<protocol::Request> requests = emulator().requests();
  ASSERT_EQ(requests.size(), before + 2);
  EXPECT_EQ(requests[before], protocol::Request::galvo_park);
  EXPECT_EQ(requests[before + 1], protocol::Request::galvo_park);
  EXPECT_FALSE(emulator().galvo_streaming());
  EXPECT_EQ(emulator().dac_fifo_fill(), 0u);
  const GalvoStatus status = galvo_->status();
  EXPECT_TRUE(status.parked);
  EXPECT_EQ(status.samples_written, 0u);
  EXPECT_EQ(status.fifo_fill, 0u);
  EXPECT_EQ(galvo_->state(), GalvoOutput::State::prepared);

  // A new prefill after the park arrives, and only it.
  const std::size_t received_before = emulator().galvo_received().size();
  const std::vector<GalvoSample> next = ramp(50);
  ASSERT_EQ(write_all(next), next.size());
  ASSERT_TRUE(wait_until(
      [&] { return emulator().galvo_received().size() >= received_before + next.size(); },
      std::chrono::seconds(3)));
  EXPECT_EQ(emulator().dac_fifo_fill(), next.size());
}

TEST_F(UsbGalvoOutputTest, UnplugIsDeviceLostAndParkDoesNotThrow) {
  galvo_->prepare(config());
  ASSERT_EQ(write_all(ramp(100)), 100u);
  galvo_->start();
  emulator().unplug();
  ASSERT_TRUE(wait_until([&] { return instrument_->device_lost(); }, std::chrono::seconds(3)));
  EXPECT_EQ(galvo_->write(ramp(10)), 0u);
  EXPECT_EQ(galvo_->status().faults & kGalvoDeviceLost, kGalvoDeviceLost);
  galvo_->park();  // noexcept: the safety path never throws
  EXPECT_TRUE(galvo_->status().parked);
}

}  // namespace
}  // namespace ioct::hal::usb::test
