// The wire formats: every field lands at the offset and in the byte order docs/usb-protocol.md
// gives, decoding refuses what is not ours, and the config names its bad keys.
#include "ioct/hal/usb/usb_protocol.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "ioct/common/config_error.hpp"
#include "ioct/hal/usb/usb_error.hpp"
#include "ioct/hal/usb/usb_instrument_config.hpp"

namespace ioct::hal::usb::protocol {
namespace {

TEST(UsbProtocol, RecordHeaderIsLittleEndianAtTheDocumentedOffsets) {
  RecordHeader header;
  header.sweep_counter = 0x0102'0304'0506'0708;
  header.samples_per_ascan = 1376;
  header.ascans_per_bscan = 512;
  header.status = kRecordClockFault | kRecordTriggerMissing;
  header.missed_triggers = 3;
  header.device_time_ns = 42;
  header.payload_bytes = 1376 * 512 * 2;
  header.records_dropped = 7;
  const auto bytes = encode(header);
  EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 4), "IOER");
  EXPECT_EQ(bytes[4], kRecordHeaderVersion);
  EXPECT_EQ(bytes[6], kRecordHeaderBytes);
  EXPECT_EQ(bytes[8], 0x08);  // sweep counter, least significant byte first
  EXPECT_EQ(bytes[15], 0x01);
  EXPECT_EQ(bytes[16] | (bytes[17] << 8), 1376);
  EXPECT_EQ(bytes[20] | (bytes[21] << 8), 512);
  EXPECT_EQ(bytes[24], 0x05);
  EXPECT_EQ(bytes[28], 3);
  EXPECT_EQ(bytes[44], 7);
  for (std::size_t i = 48; i < bytes.size(); ++i) EXPECT_EQ(bytes[i], 0) << "reserved byte " << i;

  RecordHeader decoded;
  ASSERT_TRUE(decode(bytes, decoded));
  EXPECT_EQ(decoded, header);
}

TEST(UsbProtocol, DecodingRefusesWrongMagicVersionAndShortBlocks) {
  auto bytes = encode(RecordHeader{});
  RecordHeader header;
  EXPECT_FALSE(decode(std::span(bytes).first(kRecordHeaderBytes - 1), header));
  bytes[0] ^= 1;
  EXPECT_FALSE(decode(bytes, header));
  bytes[0] ^= 1;
  bytes[4] = 2;  // header version 2
  EXPECT_FALSE(decode(bytes, header));

  auto info = encode(DeviceInfo{});
  DeviceInfo decoded_info;
  EXPECT_TRUE(decode(info, decoded_info));
  info[3] = 0;
  EXPECT_FALSE(decode(info, decoded_info));

  auto report = encode(StatusReport{});
  StatusReport decoded_report;
  EXPECT_TRUE(decode(report, decoded_report));
  EXPECT_FALSE(decode(std::span(report).first(10), decoded_report));
}

TEST(UsbProtocol, DeviceInfoAndStatusReportRoundTrip) {
  DeviceInfo info;
  info.protocol_minor = 3;
  info.firmware_version = 0x00010203;
  info.adc_bits = 14;
  info.max_samples_per_ascan = 8192;
  info.dac_fifo_capacity = 65536;
  info.record_fifo_bytes = 1u << 28;
  info.capabilities = kCapInternalClock;
  DeviceInfo info_back;
  ASSERT_TRUE(decode(encode(info), info_back));
  EXPECT_EQ(info_back, info);

  StatusReport report;
  report.status = kStatusAcquiring | kStatusGalvoFault;
  report.sweep_counter = 1ull << 40;
  report.dac_samples_output = 123456789;
  report.dac_fifo_fill = 4000;
  report.dac_underruns = 2;
  report.records_dropped = 9;
  const auto bytes = encode(report);
  EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 4), "IOST");
  StatusReport back;
  ASSERT_TRUE(decode(bytes, back));
  EXPECT_EQ(back, report);
}

TEST(UsbProtocol, GalvoCodesSpanTheFieldAndClamp) {
  EXPECT_EQ(galvo_code(1.0f), 32767);
  EXPECT_EQ(galvo_code(-1.0f), -32767);
  EXPECT_EQ(galvo_code(0.0f), 0);
  EXPECT_EQ(galvo_code(2.5f), 32767);
  EXPECT_EQ(galvo_code(-7.0f), -32767);
  EXPECT_EQ(galvo_code(std::nanf("")), 0);
  EXPECT_EQ(galvo_code(0.5f), 16384);  // 16383.5 rounds away from zero

  std::uint8_t bytes[4];
  encode_galvo_sample({-1.0f, 0.25f}, bytes);
  EXPECT_EQ(bytes[0], 0x01);  // -32767 = 0x8001, low byte first
  EXPECT_EQ(bytes[1], 0x80);
  const GalvoSample back = decode_galvo_sample(bytes);
  EXPECT_FLOAT_EQ(back.x, -1.0f);
  EXPECT_NEAR(back.y, 0.25f, 1.0f / 32767.0f);
}

TEST(UsbInstrumentConfigTest, BadKeysAreNamed) {
  const auto key_of = [](UsbInstrumentConfig config) {
    try {
      config.validate();
    } catch (const ConfigError& e) {
      return e.key();
    }
    return std::string("(valid)");
  };
  EXPECT_EQ(key_of({}), "(valid)");
  UsbInstrumentConfig c;
  c.transfer_bytes = 1000;
  EXPECT_EQ(key_of(c), "usb.transfer_bytes");
  c = {};
  c.transfers_in_flight = 0;
  EXPECT_EQ(key_of(c), "usb.transfers_in_flight");
  c = {};
  c.staging_buffers = 1;
  EXPECT_EQ(key_of(c), "usb.staging_buffers");
  c = {};
  c.galvo_transfer_bytes = 1500;
  EXPECT_EQ(key_of(c), "usb.galvo_transfer_bytes");
  c = {};
  c.vendor_id = 0;
  EXPECT_EQ(key_of(c), "usb.vendor_id");
}

TEST(UsbError, NoMemAdviceNamesTheUsbfsLimitAndItsValue) {
  const std::string missing = usbfs_memory_advice(4u << 20, "/nonexistent/usbfs_memory_mb");
  EXPECT_NE(missing.find("/nonexistent/usbfs_memory_mb is unreadable"), std::string::npos)
      << missing;
  EXPECT_NE(missing.find("4.0 MiB"), std::string::npos) << missing;
  EXPECT_NE(missing.find("usb.transfers_in_flight"), std::string::npos) << missing;
}

}  // namespace
}  // namespace ioct::hal::usb::protocol
