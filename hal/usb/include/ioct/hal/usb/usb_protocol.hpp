// The wire protocol between the host and the USB instrument's firmware (docs/usb-protocol.md):
// identifiers, endpoints, vendor control requests, and the byte layouts of the device
// information block, the bulk IN record header and the status report. Every multi-byte field is
// little-endian on the wire; encode/decode write and read bytes explicitly, so the host's own
// byte order never matters. The emulated firmware of the tests uses the same encoders.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ioct/hal/galvo_output.hpp"

namespace ioct::hal::usb::protocol {

// Placeholder identity: pid.codes' vendor ID with its test product ID 0x0001, which pid.codes
// reserves for private testing. A product must obtain its own PID; both are configurable.
inline constexpr std::uint16_t kPlaceholderVendorId = 0x1209;
inline constexpr std::uint16_t kPlaceholderProductId = 0x0001;

inline constexpr std::uint16_t kProtocolMajor = 1;  // a different major is refused
inline constexpr std::uint16_t kProtocolMinor = 0;  // minors only add, the host accepts any

inline constexpr std::uint8_t kInterfaceNumber = 0;
inline constexpr std::uint8_t kRecordEndpoint = 0x81;  // bulk IN: records, one per B-scan
inline constexpr std::uint8_t kGalvoEndpoint = 0x02;   // bulk OUT: galvo x/y samples
inline constexpr std::uint8_t kStatusEndpoint = 0x83;  // interrupt IN: a status report each ms

// bmRequestType of the vendor requests: vendor type, interface recipient, wIndex = interface.
inline constexpr std::uint8_t kRequestTypeOut = 0x41;
inline constexpr std::uint8_t kRequestTypeIn = 0xC1;

enum class Request : std::uint8_t {
  get_info = 0x01,     // IN, 32 bytes: DeviceInfo
  set_param = 0x02,    // OUT, wValue = Param, 4 bytes: the value
  get_param = 0x03,    // IN, wValue = Param, 4 bytes: the value in effect
  acq_arm = 0x10,      // sweep counter to 0, record FIFO flushed, parameters checked
  acq_start = 0x11,    // stream records from the next B-scan boundary
  acq_stop = 0x12,     // stop streaming now, flush the record FIFO (the counter keeps counting)
  galvo_start = 0x20,  // clock one queued sample out per sweep trigger
  galvo_park = 0x21,   // stop output, flush the DAC FIFO, drive the park position now
  get_status = 0x30,   // IN, 64 bytes: StatusReport
};

enum class Param : std::uint16_t {
  samples_per_ascan = 0x01,
  ascans_per_bscan = 0x02,
  flyback_sweeps = 0x03,
  clock_source = 0x04,      // 0: external k-clock, 1: internal clock
  sweep_rate_hz = 0x05,     // sweep rate for the internal clock and the software trigger
  trigger_source = 0x06,    // 0: sweep trigger input, 1: software (free running)
  trigger_level_mv = 0x07,  // signed, two's complement
  trigger_delay_samples = 0x08,
  galvo_park_x = 0x09,  // signed DAC code in the low 16 bits
  galvo_park_y = 0x0A,
};

std::string_view to_string(Param param) noexcept;
std::string_view to_string(Request request) noexcept;

// --- device information (GET_INFO) ---
inline constexpr std::uint32_t kDeviceInfoMagic = 0x4943'4F49;  // bytes "IOCI"
inline constexpr std::size_t kDeviceInfoBytes = 32;
inline constexpr std::uint32_t kCapInternalClock = 1u << 0;
inline constexpr std::uint32_t kCapSoftwareTrigger = 1u << 1;

struct DeviceInfo {
  std::uint16_t protocol_major = kProtocolMajor;
  std::uint16_t protocol_minor = kProtocolMinor;
  std::uint32_t firmware_version = 0;
  std::uint16_t adc_bits = 12;
  std::uint32_t max_samples_per_ascan = 0;
  std::uint32_t dac_fifo_capacity = 0;  // galvo samples the device buffers
  std::uint32_t record_fifo_bytes = 0;  // on-board record buffer
  std::uint32_t capabilities = 0;       // kCap* flags
  friend bool operator==(const DeviceInfo&, const DeviceInfo&) = default;
};

std::array<std::uint8_t, kDeviceInfoBytes> encode(const DeviceInfo& info) noexcept;
// False when the block is short or its magic is wrong.
bool decode(std::span<const std::uint8_t> bytes, DeviceInfo& info) noexcept;

// --- records (bulk IN 0x81) ---
// One record per B-scan: a header packet (the 64-byte header, zero-filled to wMaxPacketSize),
// the payload (ascans_per_bscan x samples_per_ascan 16-bit samples, [ascan][sample]), then zeros
// up to a multiple of wMaxPacketSize. The host lands the payload's whole packets straight in
// the ring slot and copies only the last partial packet.
inline constexpr std::uint32_t kRecordMagic = 0x5245'4F49;  // bytes "IOER"
inline constexpr std::uint16_t kRecordHeaderVersion = 1;
inline constexpr std::size_t kRecordHeaderBytes = 64;
inline constexpr std::uint32_t kRecordClockFault = 1u << 0;      // the k-clock failed in the B-scan
inline constexpr std::uint32_t kRecordOverrun = 1u << 1;         // records were dropped before it
inline constexpr std::uint32_t kRecordTriggerMissing = 1u << 2;  // sweep triggers went missing

struct RecordHeader {
  std::uint64_t sweep_counter = 0;  // counter of the B-scan's first sweep; counts every sweep
  std::uint32_t samples_per_ascan = 0;
  std::uint32_t ascans_per_bscan = 0;
  std::uint32_t status = 0;           // kRecord* flags
  std::uint32_t missed_triggers = 0;  // sweep triggers missing within this B-scan
  std::uint64_t device_time_ns = 0;   // the device's clock at the first sweep
  std::uint32_t payload_bytes = 0;    // ascans x samples x 2
  std::uint32_t records_dropped = 0;  // dropped since ARM (overrun), for diagnostics
  friend bool operator==(const RecordHeader&, const RecordHeader&) = default;
};

std::array<std::uint8_t, kRecordHeaderBytes> encode(const RecordHeader& header) noexcept;
// False when short, or the magic, header version or header size is wrong.
bool decode(std::span<const std::uint8_t> bytes, RecordHeader& header) noexcept;

// --- status reports (interrupt IN 0x83, each ms; GET_STATUS) ---
inline constexpr std::uint32_t kStatusMagic = 0x5453'4F49;  // bytes "IOST"
inline constexpr std::size_t kStatusReportBytes = 64;
inline constexpr std::uint32_t kStatusClockFault = 1u << 0;      // k-clock invalid now
inline constexpr std::uint32_t kStatusTriggerMissing = 1u << 1;  // no sweep trigger in the last ms
inline constexpr std::uint32_t kStatusRecordOverrun = 1u << 2;   // sticky since ARM
inline constexpr std::uint32_t kStatusGalvoUnderrun = 1u << 3;   // sticky since GALVO_START
inline constexpr std::uint32_t kStatusGalvoFault = 1u << 4;      // the servo driver reports a fault
inline constexpr std::uint32_t kStatusAcquiring = 1u << 5;
inline constexpr std::uint32_t kStatusGalvoStreaming = 1u << 6;

struct StatusReport {
  std::uint32_t status = 0;  // kStatus* flags
  std::uint64_t sweep_counter = 0;
  std::uint64_t dac_samples_output = 0;  // since GALVO_START
  std::uint32_t dac_fifo_fill = 0;
  std::uint32_t dac_underruns = 0;  // since GALVO_START
  std::uint32_t records_dropped = 0;
  friend bool operator==(const StatusReport&, const StatusReport&) = default;
};

std::array<std::uint8_t, kStatusReportBytes> encode(const StatusReport& report) noexcept;
bool decode(std::span<const std::uint8_t> bytes, StatusReport& report) noexcept;

// --- galvo samples (bulk OUT 0x02) ---
// Each sample is x then y, int16 little-endian; -32767..32767 spans the field [-1, 1].
inline constexpr std::size_t kGalvoSampleBytes = 4;
std::int16_t galvo_code(float position) noexcept;  // clamps to [-1, 1], rounds to nearest
float galvo_position(std::int16_t code) noexcept;
void encode_galvo_sample(const GalvoSample& sample, std::uint8_t* out) noexcept;
GalvoSample decode_galvo_sample(const std::uint8_t* in) noexcept;

// The 8-byte setup packet of a control transfer, as it appears on the wire.
struct SetupPacket {
  std::uint8_t request_type = 0;
  std::uint8_t request = 0;
  std::uint16_t value = 0;
  std::uint16_t index = 0;
  std::uint16_t length = 0;
};
SetupPacket decode_setup(const std::uint8_t* bytes) noexcept;

}  // namespace ioct::hal::usb::protocol
