// Finding and opening the instrument under umockdev: libusb enumerates the emulated device
// through udev and sysfs, opens its usbfs node, claims the interface and reads GET_INFO over a
// real control transfer; every way of not finding it says what was looked for.
#include "ioct/hal/usb/usb_instrument.hpp"

#include <gtest/gtest.h>
#include <libusb.h>

#include <string>

#include "ioct/hal/usb/usb_error.hpp"
#include "usb_test_support.hpp"

namespace ioct::hal::usb::test {
namespace {

std::string open_error(const UsbInstrumentConfig& config) {
  try {
    UsbInstrument::open(config);
  } catch (const UsbError& e) {
    return e.what();
  }
  return "(opened)";
}

class UsbInstrumentTest : public EmulatedInstrumentTest {};

TEST_F(UsbInstrumentTest, OpensTheInstrumentAndReadsItsInformation) {
  const auto instrument = UsbInstrument::open(small_transfers());
  EXPECT_EQ(instrument->info(), emulator().options().info);
  EXPECT_NE(instrument->description().find("1209:0001"), std::string::npos);
  EXPECT_NE(instrument->description().find("bus 1 device 2"), std::string::npos);
  EXPECT_EQ(instrument->max_packet_size(protocol::kRecordEndpoint), 512u);
  EXPECT_EQ(instrument->max_packet_size(protocol::kGalvoEndpoint), 512u);
  const auto requests = emulator().requests();
  ASSERT_FALSE(requests.empty());
  EXPECT_EQ(requests.front(), protocol::Request::get_info);
  // The status endpoint reports each millisecond.
  EXPECT_TRUE(wait_until([&] { return instrument->status_reports() >= 3; },
                         std::chrono::milliseconds(2000)));
  EXPECT_FALSE(instrument->device_lost());
}

TEST_F(UsbInstrumentTest, AbsentProductIsNamedWithTheKeysToCheck) {
  UsbInstrumentConfig config = small_transfers();
  config.product_id = 0x0002;
  const std::string error = open_error(config);
  EXPECT_NE(error.find("no instrument 1209:0002 is connected"), std::string::npos) << error;
  EXPECT_NE(error.find("usb.product_id"), std::string::npos) << error;
}

TEST_F(UsbInstrumentTest, SerialSelectsTheInstrumentAndAWrongOneListsThosePresent) {
  UsbInstrumentConfig config = small_transfers();
  config.serial = "EMU-0001";
  EXPECT_NO_THROW(UsbInstrument::open(config));
  config.serial = "OTHER";
  const std::string error = open_error(config);
  EXPECT_NE(error.find("usb.serial = \"OTHER\""), std::string::npos) << error;
  EXPECT_NE(error.find("EMU-0001"), std::string::npos) << error;
}

TEST_F(UsbInstrumentTest, ControlRequestsReachTheFirmwareAndRefusalsAreErrors) {
  const auto instrument = UsbInstrument::open(small_transfers());
  instrument->set_param(protocol::Param::samples_per_ascan, 1376);
  EXPECT_EQ(instrument->get_param(protocol::Param::samples_per_ascan), 1376u);
  EXPECT_EQ(emulator().params().at(protocol::Param::samples_per_ascan), 1376u);
  const auto log = emulator().control_log();
  const ControlRequest& set = log[log.size() - 2];
  EXPECT_EQ(set.setup.request_type, protocol::kRequestTypeOut);
  EXPECT_EQ(set.setup.request, static_cast<std::uint8_t>(protocol::Request::set_param));
  EXPECT_EQ(set.setup.value, static_cast<std::uint16_t>(protocol::Param::samples_per_ascan));
  EXPECT_EQ(set.setup.index, protocol::kInterfaceNumber);
  EXPECT_EQ(set.data, (std::vector<std::uint8_t>{0x60, 0x05, 0x00, 0x00}));  // 1376, LE

  // ARM before the geometry is set: the firmware STALLs the request.
  try {
    instrument->send(protocol::Request::acq_arm);
    FAIL() << "ACQ_ARM without a geometry was accepted";
  } catch (const UsbError& e) {
    EXPECT_EQ(e.libusb_code(), LIBUSB_ERROR_PIPE);
    EXPECT_NE(std::string(e.what()).find("refused the request"), std::string::npos) << e.what();
  }
}

class OtherProtocolMajor : public EmulatedInstrumentTest {
  EmulatedInstrument::Options options() const override {
    EmulatedInstrument::Options o;
    o.info.protocol_major = 2;
    return o;
  }
};

TEST_F(OtherProtocolMajor, IsRefusedWithBothVersions) {
  const std::string error = open_error(small_transfers());
  EXPECT_NE(error.find("speaks protocol 2.0; this host speaks 1.x"), std::string::npos) << error;
}

class NoStatusEndpoint : public EmulatedInstrumentTest {
  EmulatedInstrument::Options options() const override {
    EmulatedInstrument::Options o;
    o.has_status_endpoint = false;
    return o;
  }
};

TEST_F(NoStatusEndpoint, IsNotOurFirmware) {
  const std::string error = open_error(small_transfers());
  EXPECT_NE(error.find("has no interrupt IN endpoint 0x83"), std::string::npos) << error;
}

}  // namespace
}  // namespace ioct::hal::usb::test
