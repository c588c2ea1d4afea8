// The USB instrument's firmware, emulated at the usbfs ioctl level inside a umockdev testbed.
//
// The test process runs under libumockdev-preload (see umockdev_main.cpp). The testbed shows
// libusb a USB device in sysfs/udev and a /dev/bus/usb node whose ioctls (SUBMITURB, REAPURB,
// DISCARDURB, CLEAR_HALT, ...) land in on_ioctl() on umockdev's worker thread. There the device
// speaks docs/usb-protocol.md: vendor control requests, records on bulk IN 0x81 generated on
// demand as a byte stream cut into whatever the host asks for, galvo samples taken from bulk
// OUT 0x02 into a modelled DAC FIFO, status reports on interrupt IN 0x83 each millisecond. Faults
// are injected from the test thread: unplug/replug (with hotplug uevents), stalls of the record
// stream (no triggers), dropped records, bad headers, an endpoint halt, the usbfs memory limit.
#pragma once

#include <umockdev.h>

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "ioct/hal/galvo_output.hpp"
#include "ioct/hal/usb/usb_protocol.hpp"

namespace ioct::hal::usb::test {

// The sample the emulated ADC records for sample `sample` of the sweep with counter `sweep`.
std::uint16_t emulated_sample(std::uint64_t sweep, std::uint32_t sample, std::uint16_t adc_bits);

struct ControlRequest {
  protocol::SetupPacket setup;
  std::vector<std::uint8_t> data;  // OUT data stage
};

class EmulatedInstrument {
 public:
  struct Options {
    std::uint16_t vendor_id = protocol::kPlaceholderVendorId;
    std::uint16_t product_id = protocol::kPlaceholderProductId;
    std::string serial = "EMU-0001";
    std::uint16_t bulk_packet_bytes = 512;  // USB 2.0 high speed
    bool has_status_endpoint = true;
    protocol::DeviceInfo info = default_info();
    // Records lost around every restart after the first START (the counter runs on meanwhile).
    std::uint32_t restart_gap_records = 3;
    // Galvo samples the DAC clocks out per status-report millisecond while streaming.
    std::uint32_t dac_samples_per_ms = 100;

    static protocol::DeviceInfo default_info();
  };

  // True when this process runs under libumockdev-preload with a testbed in place; creating a
  // testbed is what makes the check meaningful, so call it after construction.
  static bool in_mock_environment();

  EmulatedInstrument();  // default options
  explicit EmulatedInstrument(const Options& options);
  ~EmulatedInstrument();
  EmulatedInstrument(const EmulatedInstrument&) = delete;
  EmulatedInstrument& operator=(const EmulatedInstrument&) = delete;

  const Options& options() const noexcept { return options_; }
  // The testbed's sysfs root, for files such as module/usbcore/parameters/usbfs_memory_mb.
  std::string sys_dir() const;

  // --- hotplug ---
  // Pending URBs complete with -ESHUTDOWN, new ones fail with ENODEV, udev sees "remove".
  void unplug();
  // The device is back with its settings lost (power cycled); udev sees "add".
  void replug();

  // --- fault injection ---
  // Serve no more records after `records` in total since ARM (the sweep trigger vanished);
  // std::nullopt serves again.
  void stall_after_records(std::optional<std::uint64_t> records);
  // The record with index `record` (since ARM) and the `count - 1` after it are never sent:
  // the on-board FIFO overflowed. The next record sent carries kRecordOverrun.
  void drop_records(std::uint64_t record, std::uint32_t count);
  // Record `record` carries these kRecord* status bits and missed-trigger count.
  void flag_record(std::uint64_t record, std::uint32_t status, std::uint32_t missed_triggers);
  // Record `record` goes out with a broken magic.
  void corrupt_record(std::uint64_t record);
  // The next bulk IN URB completes with -EPIPE (the endpoint halted) until CLEAR_HALT.
  void halt_record_endpoint();
  // SUBMITURB fails with ENOMEM once the bulk bytes in flight would exceed `bytes` (0: no limit).
  void limit_urb_bytes(std::uint64_t bytes);
  // GET_PARAM of `param` reads back `value` whatever was set (firmware that clamps a setting).
  void override_param(protocol::Param param, std::uint32_t value);
  // The servo driver fault bit in the status reports.
  void set_galvo_fault(bool fault);

  // --- what the host did ---
  std::vector<ControlRequest> control_log() const;
  // Vendor requests only, by request code, in order.
  std::vector<protocol::Request> requests() const;
  std::map<protocol::Param, std::uint32_t> params() const;
  std::uint64_t records_sent() const;
  std::vector<std::uint32_t> galvo_received() const;  // packed codes: x low 16, y high 16 bits
  std::uint64_t dac_samples_output() const;
  std::uint32_t dac_fifo_fill() const;
  bool acquiring() const;
  bool galvo_streaming() const;
  std::uint32_t clear_halts(std::uint8_t endpoint) const;
  std::uint64_t bulk_in_bytes_in_flight_peak() const;

 private:
  // URBs belong to the descriptor that submitted them; those of a closed descriptor (before a
  // reconnection) stay queued, unreaped, until the emulator goes (umockdev 0.17 does not report
  // closed descriptors reliably).
  struct Urb {
    UMockdevIoctlClient* client = nullptr;
    UMockdevIoctlData* data = nullptr;  // the client's struct usbdevfs_urb (owned reference)
    unsigned char type = 0;
    unsigned char endpoint = 0;
    int length = 0;
  };

  static gboolean on_ioctl(UMockdevIoctlBase* handler, UMockdevIoctlClient* client, gpointer self);
  bool handle_ioctl(UMockdevIoctlClient* client);
  void submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg);
  void reap(UMockdevIoctlClient* client, UMockdevIoctlData* arg);
  void discard(UMockdevIoctlClient* client, UMockdevIoctlData* arg);
  // Completes `urb` into the REAPURB argument `arg` with `status`; takes the URB's reference.
  void complete_urb(UMockdevIoctlClient* client, UMockdevIoctlData* arg, Urb urb, int status,
                    int actual);
  std::optional<std::size_t> next_urb(UMockdevIoctlClient* client, unsigned char endpoint) const;
  int run_control(unsigned char* buffer, int length);
  void fill_records(unsigned char* out, int length);
  void generate_record();
  void tick_status(std::chrono::steady_clock::time_point now);
  protocol::StatusReport status_report() const;
  std::uint64_t sweeps_per_bscan() const;
  std::string descriptors_hex() const;
  void add_device();

  Options options_;
  UMockdevTestbed* testbed_ = nullptr;
  UMockdevIoctlBase* handler_ = nullptr;
  std::string syspath_;
  std::string devnode_;

  mutable std::mutex mutex_;
  bool unplugged_ = false;
  std::deque<Urb> pending_;
  std::deque<Urb> discarded_;
  std::vector<ControlRequest> control_log_;
  std::map<protocol::Param, std::uint32_t> params_;
  std::map<protocol::Param, std::uint32_t> overrides_;
  std::map<std::uint8_t, std::uint32_t> clear_halts_;

  // Acquisition.
  bool armed_ = false;
  bool acquiring_ = false;
  bool started_since_arm_ = false;
  bool record_endpoint_halted_ = false;
  std::uint64_t next_record_ = 0;  // record index since ARM (counter = index x sweeps/B-scan)
  std::uint64_t records_sent_ = 0;
  std::vector<std::uint8_t> record_bytes_;  // the record being sent
  std::size_t record_position_ = 0;
  std::optional<std::uint64_t> stall_after_;
  std::map<std::uint64_t, std::uint32_t> drops_;
  std::map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> flags_;
  std::map<std::uint64_t, bool> corrupt_;
  bool overrun_pending_ = false;
  std::uint32_t records_dropped_ = 0;
  std::uint64_t urb_byte_limit_ = 0;
  std::uint64_t bulk_bytes_in_flight_ = 0;
  std::uint64_t bulk_bytes_peak_ = 0;

  // Galvo DAC.
  bool galvo_streaming_ = false;
  bool galvo_fault_ = false;
  std::deque<std::uint32_t> dac_fifo_;
  std::vector<std::uint32_t> galvo_received_;
  std::uint64_t dac_output_ = 0;
  std::uint32_t dac_underruns_ = 0;
  std::chrono::steady_clock::time_point last_status_{};
};

}  // namespace ioct::hal::usb::test
