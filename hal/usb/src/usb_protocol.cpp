#include "ioct/hal/usb/usb_protocol.hpp"

#include <algorithm>
#include <cmath>

namespace ioct::hal::usb::protocol {
namespace {

void put16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
void put32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
std::uint16_t get16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
std::uint32_t get32(const std::uint8_t* p) noexcept {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
std::uint64_t get64(const std::uint8_t* p) noexcept {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

std::string_view to_string(Param param) noexcept {
  switch (param) {
    case Param::samples_per_ascan:
      return "samples_per_ascan";
    case Param::ascans_per_bscan:
      return "ascans_per_bscan";
    case Param::flyback_sweeps:
      return "flyback_sweeps";
    case Param::clock_source:
      return "clock_source";
    case Param::sweep_rate_hz:
      return "sweep_rate_hz";
    case Param::trigger_source:
      return "trigger_source";
    case Param::trigger_level_mv:
      return "trigger_level_mv";
    case Param::trigger_delay_samples:
      return "trigger_delay_samples";
    case Param::galvo_park_x:
      return "galvo_park_x";
    case Param::galvo_park_y:
      return "galvo_park_y";
  }
  return "unknown";
}

std::string_view to_string(Request request) noexcept {
  switch (request) {
    case Request::get_info:
      return "GET_INFO";
    case Request::set_param:
      return "SET_PARAM";
    case Request::get_param:
      return "GET_PARAM";
    case Request::acq_arm:
      return "ACQ_ARM";
    case Request::acq_start:
      return "ACQ_START";
    case Request::acq_stop:
      return "ACQ_STOP";
    case Request::galvo_start:
      return "GALVO_START";
    case Request::galvo_park:
      return "GALVO_PARK";
    case Request::get_status:
      return "GET_STATUS";
  }
  return "unknown";
}

// DeviceInfo: 0 magic, 4 major, 6 minor, 8 firmware, 12 adc_bits, 14 reserved, 16 max samples,
// 20 DAC FIFO capacity, 24 record FIFO bytes, 28 capabilities.
std::array<std::uint8_t, kDeviceInfoBytes> encode(const DeviceInfo& info) noexcept {
  std::array<std::uint8_t, kDeviceInfoBytes> b{};
  put32(&b[0], kDeviceInfoMagic);
  put16(&b[4], info.protocol_major);
  put16(&b[6], info.protocol_minor);
  put32(&b[8], info.firmware_version);
  put16(&b[12], info.adc_bits);
  put32(&b[16], info.max_samples_per_ascan);
  put32(&b[20], info.dac_fifo_capacity);
  put32(&b[24], info.record_fifo_bytes);
  put32(&b[28], info.capabilities);
  return b;
}

bool decode(std::span<const std::uint8_t> bytes, DeviceInfo& info) noexcept {
  if (bytes.size() < kDeviceInfoBytes || get32(&bytes[0]) != kDeviceInfoMagic) return false;
  info.protocol_major = get16(&bytes[4]);
  info.protocol_minor = get16(&bytes[6]);
  info.firmware_version = get32(&bytes[8]);
  info.adc_bits = get16(&bytes[12]);
  info.max_samples_per_ascan = get32(&bytes[16]);
  info.dac_fifo_capacity = get32(&bytes[20]);
  info.record_fifo_bytes = get32(&bytes[24]);
  info.capabilities = get32(&bytes[28]);
  return true;
}

// RecordHeader: 0 magic, 4 header version, 6 header bytes, 8 sweep counter, 16 samples per
// A-scan, 20 A-scans per B-scan, 24 status, 28 missed triggers, 32 device time, 40 payload
// bytes, 44 records dropped, 48..63 reserved (zero).
std::array<std::uint8_t, kRecordHeaderBytes> encode(const RecordHeader& header) noexcept {
  std::array<std::uint8_t, kRecordHeaderBytes> b{};
  put32(&b[0], kRecordMagic);
  put16(&b[4], kRecordHeaderVersion);
  put16(&b[6], static_cast<std::uint16_t>(kRecordHeaderBytes));
  put64(&b[8], header.sweep_counter);
  put32(&b[16], header.samples_per_ascan);
  put32(&b[20], header.ascans_per_bscan);
  put32(&b[24], header.status);
  put32(&b[28], header.missed_triggers);
  put64(&b[32], header.device_time_ns);
  put32(&b[40], header.payload_bytes);
  put32(&b[44], header.records_dropped);
  return b;
}

bool decode(std::span<const std::uint8_t> bytes, RecordHeader& header) noexcept {
  if (bytes.size() < kRecordHeaderBytes) return false;
  if (get32(&bytes[0]) != kRecordMagic || get16(&bytes[4]) != kRecordHeaderVersion ||
      get16(&bytes[6]) != kRecordHeaderBytes) {
    return false;
  }
  header.sweep_counter = get64(&bytes[8]);
  header.samples_per_ascan = get32(&bytes[16]);
  header.ascans_per_bscan = get32(&bytes[20]);
  header.status = get32(&bytes[24]);
  header.missed_triggers = get32(&bytes[28]);
  header.device_time_ns = get64(&bytes[32]);
  header.payload_bytes = get32(&bytes[40]);
  header.records_dropped = get32(&bytes[44]);
  return true;
}

// StatusReport: 0 magic, 4 status, 8 sweep counter, 16 DAC samples output, 24 DAC FIFO fill,
// 28 DAC underruns, 32 records dropped, 36..63 reserved (zero).
std::array<std::uint8_t, kStatusReportBytes> encode(const StatusReport& report) noexcept {
  std::array<std::uint8_t, kStatusReportBytes> b{};
  put32(&b[0], kStatusMagic);
  put32(&b[4], report.status);
  put64(&b[8], report.sweep_counter);
  put64(&b[16], report.dac_samples_output);
  put32(&b[24], report.dac_fifo_fill);
  put32(&b[28], report.dac_underruns);
  put32(&b[32], report.records_dropped);
  return b;
}

bool decode(std::span<const std::uint8_t> bytes, StatusReport& report) noexcept {
  if (bytes.size() < kStatusReportBytes || get32(&bytes[0]) != kStatusMagic) return false;
  report.status = get32(&bytes[4]);
  report.sweep_counter = get64(&bytes[8]);
  report.dac_samples_output = get64(&bytes[16]);
  report.dac_fifo_fill = get32(&bytes[24]);
  report.dac_underruns = get32(&bytes[28]);
  report.records_dropped = get32(&bytes[32]);
  return true;
}

std::int16_t galvo_code(float position) noexcept {
  // NaN parks at the centre rather than at an arbitrary code.
  const float clamped = std::isnan(position) ? 0.0f : std::clamp(position, -1.0f, 1.0f);
  return static_cast<std::int16_t>(std::lround(clamped * 32767.0f));
}

float galvo_position(std::int16_t code) noexcept {
  return static_cast<float>(code) / 32767.0f;
}

void encode_galvo_sample(const GalvoSample& sample, std::uint8_t* out) noexcept {
  put16(out, static_cast<std::uint16_t>(galvo_code(sample.x)));
  put16(out + 2, static_cast<std::uint16_t>(galvo_code(sample.y)));
}

GalvoSample decode_galvo_sample(const std::uint8_t* in) noexcept {
  return {galvo_position(static_cast<std::int16_t>(get16(in))),
          galvo_position(static_cast<std::int16_t>(get16(in + 2)))};
}

SetupPacket decode_setup(const std::uint8_t* bytes) noexcept {
  return {bytes[0], bytes[1], get16(bytes + 2), get16(bytes + 4), get16(bytes + 6)};
}

}  // namespace ioct::hal::usb::protocol
