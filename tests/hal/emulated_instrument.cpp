#include "emulated_instrument.hpp"

// clang-format off: linux/usbdevice_fs.h needs linux/ioctl.h first.
#include <linux/ioctl.h>
#include <linux/usbdevice_fs.h>
// clang-format on

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace ioct::hal::usb::test {
namespace {

constexpr const char* kSysPath = "/sys/devices/pci0000:00/0000:00:14.0/usb1/1-1";
constexpr const char* kDevicePath = "/devices/pci0000:00/0000:00:14.0/usb1/1-1";
constexpr const char* kDevNode = "/dev/bus/usb/001/002";
constexpr std::size_t kSetupBytes = 8;

std::string hex(const std::vector<std::uint8_t>& bytes) {
  std::string text;
  char byte[3];
  for (std::uint8_t b : bytes) {
    std::snprintf(byte, sizeof(byte), "%02x", b);
    text += byte;
  }
  return text;
}

void put16(std::vector<std::uint8_t>& v, std::uint16_t x) {
  v.push_back(static_cast<std::uint8_t>(x));
  v.push_back(static_cast<std::uint8_t>(x >> 8));
}

std::uint32_t get32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0] | (p[1] << 8) | (p[2] << 16)) |
         (static_cast<std::uint32_t>(p[3]) << 24);
}

void put32(unsigned char* p, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}

bool is_bulk_in(const usbdevfs_urb& urb) {
  return urb.type == USBDEVFS_URB_TYPE_BULK && (urb.endpoint & 0x80) != 0;
}

}  // namespace

std::uint16_t emulated_sample(std::uint64_t sweep, std::uint32_t sample, std::uint16_t adc_bits) {
  const std::uint64_t mixed = (sweep * 2654435761u) ^ (std::uint64_t{sample} * 40503u) ^
                              (sweep >> 3) ^ (std::uint64_t{sample} << 5);
  return static_cast<std::uint16_t>(mixed & ((1u << adc_bits) - 1u));
}

protocol::DeviceInfo EmulatedInstrument::Options::default_info() {
  protocol::DeviceInfo info;
  info.firmware_version = 0x0001'0002;
  info.adc_bits = 12;
  info.max_samples_per_ascan = 4096;
  info.dac_fifo_capacity = 4096;
  info.record_fifo_bytes = 64u << 20;
  info.capabilities = protocol::kCapInternalClock | protocol::kCapSoftwareTrigger;
  return info;
}

bool EmulatedInstrument::in_mock_environment() {
  return umockdev_in_mock_environment() != 0;
}

EmulatedInstrument::EmulatedInstrument() : EmulatedInstrument(Options{}) {}

EmulatedInstrument::EmulatedInstrument(const Options& options) : options_(options) {
  testbed_ = umockdev_testbed_new();
  handler_ = umockdev_ioctl_base_new();
  g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(on_ioctl), this);
  GError* error = nullptr;
  if (umockdev_testbed_attach_ioctl(testbed_, kDevNode, handler_, &error) == 0) {
    const std::string text = error != nullptr ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev: cannot attach the usbfs handler: " + text);
  }
  add_device();
}

EmulatedInstrument::~EmulatedInstrument() {
  {
    std::lock_guard lock(mutex_);
    for (Urb& urb : pending_) g_object_unref(urb.data);
    for (Urb& urb : discarded_) g_object_unref(urb.data);
    pending_.clear();
    discarded_.clear();
  }
  g_clear_object(&handler_);
  g_clear_object(&testbed_);
}

std::string EmulatedInstrument::descriptors_hex() const {
  std::vector<std::uint8_t> d = {18, 1};
  put16(d, 0x0200);                           // bcdUSB 2.00 (high speed)
  d.insert(d.end(), {0xFF, 0x00, 0x00, 64});  // vendor class, EP0 64 bytes
  put16(d, options_.vendor_id);
  put16(d, options_.product_id);
  put16(d, 0x0100);                 // bcdDevice
  d.insert(d.end(), {1, 2, 3, 1});  // strings: manufacturer, product, serial; 1 configuration

  const std::uint8_t endpoints = options_.has_status_endpoint ? 3 : 2;
  const std::uint16_t total = static_cast<std::uint16_t>(9 + 9 + 7 * endpoints);
  d.insert(d.end(), {9, 2});
  put16(d, total);
  d.insert(d.end(), {1, 1, 0, 0x80, 0xFA});
  d.insert(d.end(), {9, 4, 0, 0, endpoints, 0xFF, 0x00, 0x00, 0});
  d.insert(d.end(), {7, 5, protocol::kRecordEndpoint, 0x02});
  put16(d, options_.bulk_packet_bytes);
  d.push_back(0);
  d.insert(d.end(), {7, 5, protocol::kGalvoEndpoint, 0x02});
  put16(d, options_.bulk_packet_bytes);
  d.push_back(0);
  if (options_.has_status_endpoint) {
    d.insert(d.end(), {7, 5, protocol::kStatusEndpoint, 0x03});
    put16(d, 64);
    d.push_back(4);  // 2^(4-1) microframes: 1 ms
  }
  return hex(d);
}

void EmulatedInstrument::add_device() {
  const std::string description = std::string("P: ") + kDevicePath +
                                  "\n"
                                  "N: bus/usb/001/002\n"
                                  "E: SUBSYSTEM=usb\n"
                                  "E: DEVTYPE=usb_device\n"
                                  "E: BUSNUM=001\n"
                                  "E: DEVNUM=002\n"
                                  "E: DEVNAME=/dev/bus/usb/001/002\n"
                                  "A: busnum=1\\n\n"
                                  "A: devnum=2\\n\n"
                                  "A: speed=480\\n\n"
                                  "A: bConfigurationValue=1\\n\n"
                                  "H: descriptors=" +
                                  descriptors_hex() + "\n";
  GError* error = nullptr;
  if (umockdev_testbed_add_from_string(testbed_, description.c_str(), &error) == 0) {
    const std::string text = error != nullptr ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev: cannot add the instrument: " + text);
  }
  syspath_ = kSysPath;
  devnode_ = kDevNode;
}

std::string EmulatedInstrument::sys_dir() const {
  gchar* dir = umockdev_testbed_get_sys_dir(testbed_);
  std::string text = dir;
  g_free(dir);
  return text;
}

// --- hotplug ---

void EmulatedInstrument::unplug() {
  {
    std::lock_guard lock(mutex_);
    unplugged_ = true;
    acquiring_ = false;
    galvo_streaming_ = false;
  }
  umockdev_testbed_uevent(testbed_, syspath_.c_str(), "remove");
}

void EmulatedInstrument::replug() {
  {
    std::lock_guard lock(mutex_);
    unplugged_ = false;
    params_.clear();  // a power-cycled instrument has forgotten its settings
    armed_ = acquiring_ = started_since_arm_ = false;
    record_bytes_.clear();
    record_position_ = 0;
    galvo_streaming_ = false;
    dac_fifo_.clear();
  }
  umockdev_testbed_uevent(testbed_, syspath_.c_str(), "add");
}

// --- fault injection ---

void EmulatedInstrument::stall_after_records(std::optional<std::uint64_t> records) {
  std::lock_guard lock(mutex_);
  stall_after_ = records;
}

void EmulatedInstrument::drop_records(std::uint64_t record, std::uint32_t count) {
  std::lock_guard lock(mutex_);
  drops_[record] = count;
}

void EmulatedInstrument::flag_record(std::uint64_t record, std::uint32_t status,
                                     std::uint32_t missed_triggers) {
  std::lock_guard lock(mutex_);
  flags_[record] = {status, missed_triggers};
}

void EmulatedInstrument::corrupt_record(std::uint64_t record) {
  std::lock_guard lock(mutex_);
  corrupt_[record] = true;
}

void EmulatedInstrument::halt_record_endpoint() {
  std::lock_guard lock(mutex_);
  record_endpoint_halted_ = true;
}

void EmulatedInstrument::limit_urb_bytes(std::uint64_t bytes) {
  std::lock_guard lock(mutex_);
  urb_byte_limit_ = bytes;
}

void EmulatedInstrument::override_param(protocol::Param param, std::uint32_t value) {
  std::lock_guard lock(mutex_);
  overrides_[param] = value;
}

void EmulatedInstrument::set_galvo_fault(bool fault) {
  std::lock_guard lock(mutex_);
  galvo_fault_ = fault;
}

// --- observation ---

std::vector<ControlRequest> EmulatedInstrument::control_log() const {
  std::lock_guard lock(mutex_);
  return control_log_;
}

std::vector<protocol::Request> EmulatedInstrument::requests() const {
  std::lock_guard lock(mutex_);
  std::vector<protocol::Request> out;
  for (const ControlRequest& r : control_log_) {
    if ((r.setup.request_type & 0x60) == 0x40) {
      out.push_back(static_cast<protocol::Request>(r.setup.request));
    }
  }
  return out;
}

std::map<protocol::Param, std::uint32_t> EmulatedInstrument::params() const {
  std::lock_guard lock(mutex_);
  return params_;
}

std::uint64_t EmulatedInstrument::records_sent() const {
  std::lock_guard lock(mutex_);
  return records_sent_;
}

std::vector<std::uint32_t> EmulatedInstrument::galvo_received() const {
  std::lock_guard lock(mutex_);
  return galvo_received_;
}

std::uint64_t EmulatedInstrument::dac_samples_output() const {
  std::lock_guard lock(mutex_);
  return dac_output_;
}

std::uint32_t EmulatedInstrument::dac_fifo_fill() const {
  std::lock_guard lock(mutex_);
  return static_cast<std::uint32_t>(dac_fifo_.size());
}

bool EmulatedInstrument::acquiring() const {
  std::lock_guard lock(mutex_);
  return acquiring_;
}

bool EmulatedInstrument::galvo_streaming() const {
  std::lock_guard lock(mutex_);
  return galvo_streaming_;
}

std::uint32_t EmulatedInstrument::clear_halts(std::uint8_t endpoint) const {
  std::lock_guard lock(mutex_);
  const auto it = clear_halts_.find(endpoint);
  return it == clear_halts_.end() ? 0 : it->second;
}

std::uint64_t EmulatedInstrument::bulk_in_bytes_in_flight_peak() const {
  std::lock_guard lock(mutex_);
  return bulk_bytes_peak_;
}

// --- the usbfs ioctls (umockdev's worker thread) ---

gboolean EmulatedInstrument::on_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                      gpointer self) {
  return static_cast<EmulatedInstrument*>(self)->handle_ioctl(client) ? TRUE : FALSE;
}

bool EmulatedInstrument::handle_ioctl(UMockdevIoctlClient* client) {
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  std::lock_guard lock(mutex_);
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES: {
      UMockdevIoctlData* caps = umockdev_ioctl_data_resolve(arg, 0, sizeof(guint32), nullptr);
      *reinterpret_cast<guint32*>(caps->data) =
          USBDEVFS_CAP_BULK_CONTINUATION | USBDEVFS_CAP_NO_PACKET_SIZE_LIM |
          USBDEVFS_CAP_REAP_AFTER_DISCONNECT | USBDEVFS_CAP_ZERO_PACKET;
      g_object_unref(caps);
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    }
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_DISCONNECT_CLAIM:  // no kernel driver to disconnect: a plain claim
    case USBDEVFS_RELEASEINTERFACE:
    case USBDEVFS_SETCONFIGURATION:
    case USBDEVFS_RESET:
    case USBDEVFS_RESETEP:
      if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
      } else {
        umockdev_ioctl_client_complete(client, 0, 0);
      }
      return true;
    case USBDEVFS_GETDRIVER:
    case USBDEVFS_IOCTL:  // disconnect/connect a kernel driver: none is bound
      umockdev_ioctl_client_complete(client, -1, ENODATA);
      return true;
    case USBDEVFS_CLEAR_HALT: {
      if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return true;
      }
      UMockdevIoctlData* ep = umockdev_ioctl_data_resolve(arg, 0, sizeof(unsigned int), nullptr);
      const auto endpoint = static_cast<std::uint8_t>(*reinterpret_cast<unsigned int*>(ep->data));
      g_object_unref(ep);
      ++clear_halts_[endpoint];
      if (endpoint == protocol::kRecordEndpoint) record_endpoint_halted_ = false;
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    }
    case USBDEVFS_SUBMITURB:
      submit(client, arg);
      return true;
    case USBDEVFS_REAPURB:
    case USBDEVFS_REAPURBNDELAY:
      reap(client, arg);
      return true;
    case USBDEVFS_DISCARDURB:
      discard(client, arg);
      return true;
    default:
      std::fprintf(stderr, "emulated instrument: unhandled usbfs ioctl 0x%lx\n", request);
      umockdev_ioctl_client_complete(client, -1, ENOTTY);
      return true;
  }
}

void EmulatedInstrument::submit(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  if (unplugged_) {
    umockdev_ioctl_client_complete(client, -1, ENODEV);
    return;
  }
  UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), nullptr);
  auto* urb = reinterpret_cast<usbdevfs_urb*>(data->data);
  if (is_bulk_in(*urb) && urb_byte_limit_ != 0 &&
      bulk_bytes_in_flight_ + static_cast<std::uint64_t>(urb->buffer_length) > urb_byte_limit_) {
    g_object_unref(data);
    umockdev_ioctl_client_complete(client, -1, ENOMEM);  // usbfs_memory_mb exhausted
    return;
  }
  // The buffer becomes a local copy that is synced back when the URB is reaped.
  UMockdevIoctlData* buffer = umockdev_ioctl_data_resolve(
      data, G_STRUCT_OFFSET(usbdevfs_urb, buffer), static_cast<gsize>(urb->buffer_length), nullptr);
  g_object_unref(buffer);
  if (is_bulk_in(*urb)) {
    bulk_bytes_in_flight_ += static_cast<std::uint64_t>(urb->buffer_length);
    bulk_bytes_peak_ = std::max(bulk_bytes_peak_, bulk_bytes_in_flight_);
  }
  pending_.push_back(Urb{client, data, urb->type, urb->endpoint, urb->buffer_length});
  umockdev_ioctl_client_complete(client, 0, 0);
}

void EmulatedInstrument::discard(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  const gulong address = *reinterpret_cast<gulong*>(arg->data);
  for (auto it = pending_.begin(); it != pending_.end(); ++it) {
    if (it->client == client && it->data->client_addr == address) {
      if (it->type == USBDEVFS_URB_TYPE_BULK && (it->endpoint & 0x80) != 0) {
        bulk_bytes_in_flight_ -= static_cast<std::uint64_t>(it->length);
      }
      discarded_.push_back(*it);
      pending_.erase(it);
      umockdev_ioctl_client_complete(client, 0, 0);
      return;
    }
  }
  umockdev_ioctl_client_complete(client, -1, EINVAL);  // already completed
}

std::optional<std::size_t> EmulatedInstrument::next_urb(UMockdevIoctlClient* client,
                                                        unsigned char endpoint) const {
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    if (pending_[i].client == client && pending_[i].endpoint == endpoint &&
        (endpoint != 0 || pending_[i].type == USBDEVFS_URB_TYPE_CONTROL)) {
      return i;
    }
  }
  return std::nullopt;
}

void EmulatedInstrument::complete_urb(UMockdevIoctlClient* client, UMockdevIoctlData* arg, Urb urb,
                                      int status, int actual) {
  auto* u = reinterpret_cast<usbdevfs_urb*>(urb.data->data);
  u->status = status;
  u->actual_length = actual;
  if (urb.type == USBDEVFS_URB_TYPE_BULK && (urb.endpoint & 0x80) != 0) {
    bulk_bytes_in_flight_ -= static_cast<std::uint64_t>(urb.length);
  }
  UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(gpointer), nullptr);
  umockdev_ioctl_data_set_ptr(pointer, 0, urb.data);
  g_object_unref(pointer);
  umockdev_ioctl_client_complete(client, 0, 0);
  g_object_unref(urb.data);
}

void EmulatedInstrument::reap(UMockdevIoctlClient* client, UMockdevIoctlData* arg) {
  const auto take = [&](std::size_t index) {
    Urb urb = pending_[index];
    pending_.erase(pending_.begin() + static_cast<std::ptrdiff_t>(index));
    return urb;
  };
  // Cancelled URBs come back first, with -ENOENT, as the kernel returns them.
  for (auto it = discarded_.begin(); it != discarded_.end(); ++it) {
    if (it->client == client) {
      Urb urb = *it;
      discarded_.erase(it);
      auto* u = reinterpret_cast<usbdevfs_urb*>(urb.data->data);
      u->status = -ENOENT;
      u->actual_length = 0;
      UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(gpointer), nullptr);
      umockdev_ioctl_data_set_ptr(pointer, 0, urb.data);
      g_object_unref(pointer);
      umockdev_ioctl_client_complete(client, 0, 0);
      g_object_unref(urb.data);
      return;
    }
  }
  if (unplugged_) {
    for (std::size_t i = 0; i < pending_.size(); ++i) {
      if (pending_[i].client == client) {
        complete_urb(client, arg, take(i), -ESHUTDOWN, 0);
        return;
      }
    }
    umockdev_ioctl_client_complete(client, -1, ENODEV);
    return;
  }

  if (const auto i = next_urb(client, 0)) {
    Urb urb = take(*i);
    auto* u = reinterpret_cast<usbdevfs_urb*>(urb.data->data);
    const int actual = run_control(static_cast<unsigned char*>(u->buffer), urb.length);
    complete_urb(client, arg, urb, actual < 0 ? -EPIPE : 0, std::max(actual, 0));
    return;
  }

  const auto now = std::chrono::steady_clock::now();
  if (now - last_status_ >= std::chrono::milliseconds(1)) {
    if (const auto i = next_urb(client, protocol::kStatusEndpoint)) {
      tick_status(now);
      Urb urb = take(*i);
      const auto report = protocol::encode(status_report());
      auto* u = reinterpret_cast<usbdevfs_urb*>(urb.data->data);
      const int n = std::min<int>(urb.length, static_cast<int>(report.size()));
      std::memcpy(u->buffer, report.data(), static_cast<std::size_t>(n));
      complete_urb(client, arg, urb, 0, n);
      return;
    }
  }

  if (const auto i = next_urb(client, protocol::kGalvoEndpoint)) {
    const std::size_t samples =
        static_cast<std::size_t>(pending_[*i].length) / protocol::kGalvoSampleBytes;
    if (dac_fifo_.size() + samples <= options_.info.dac_fifo_capacity) {  // else: NAK
      Urb urb = take(*i);
      const auto* bytes = static_cast<const unsigned char*>(
          reinterpret_cast<usbdevfs_urb*>(urb.data->data)->buffer);
      for (std::size_t s = 0; s < samples; ++s) {
        const std::uint32_t code = get32(bytes + 4 * s);
        dac_fifo_.push_back(code);
        galvo_received_.push_back(code);
      }
      complete_urb(client, arg, urb, 0, urb.length);
      return;
    }
  }

  if (const auto i = next_urb(client, protocol::kRecordEndpoint)) {
    if (record_endpoint_halted_) {
      complete_urb(client, arg, take(*i), -EPIPE, 0);
      return;
    }
    if (acquiring_) {
      // A record is sent whole once started; a stall takes effect at a record boundary.
      const bool mid_record = record_position_ < record_bytes_.size();
      const bool stalled = stall_after_.has_value() && records_sent_ >= *stall_after_;
      if (mid_record || !stalled) {
        Urb urb = take(*i);
        auto* u = reinterpret_cast<usbdevfs_urb*>(urb.data->data);
        fill_records(static_cast<unsigned char*>(u->buffer), urb.length);
        complete_urb(client, arg, urb, 0, urb.length);
        return;
      }
    }
  }
  umockdev_ioctl_client_complete(client, -1, EAGAIN);
}

// --- records ---

std::uint64_t EmulatedInstrument::sweeps_per_bscan() const {
  const auto get = [&](protocol::Param p) {
    const auto it = params_.find(p);
    return it == params_.end() ? 0u : it->second;
  };
  return std::uint64_t{get(protocol::Param::ascans_per_bscan)} +
         get(protocol::Param::flyback_sweeps);
}

void EmulatedInstrument::generate_record() {
  while (drops_.count(next_record_) != 0) {
    const std::uint32_t count = drops_[next_record_];
    drops_.erase(next_record_);
    next_record_ += count;
    records_dropped_ += count;
    overrun_pending_ = true;
  }
  const std::uint32_t samples = params_[protocol::Param::samples_per_ascan];
  const std::uint32_t ascans = params_[protocol::Param::ascans_per_bscan];
  const std::uint64_t counter = next_record_ * sweeps_per_bscan();
  const std::size_t packet = options_.bulk_packet_bytes;
  const std::size_t payload = std::size_t{samples} * ascans * 2;
  const std::size_t padded = (payload + packet - 1) / packet * packet;

  protocol::RecordHeader header;
  header.sweep_counter = counter;
  header.samples_per_ascan = samples;
  header.ascans_per_bscan = ascans;
  header.payload_bytes = static_cast<std::uint32_t>(payload);
  header.device_time_ns = counter * 10'000;
  header.records_dropped = records_dropped_;
  if (overrun_pending_) header.status |= protocol::kRecordOverrun;
  overrun_pending_ = false;
  if (const auto it = flags_.find(next_record_); it != flags_.end()) {
    header.status |= it->second.first;
    header.missed_triggers = it->second.second;
  }
  record_bytes_.assign(packet + padded, 0);
  const auto encoded = protocol::encode(header);
  std::copy(encoded.begin(), encoded.end(), record_bytes_.begin());
  if (corrupt_.count(next_record_) != 0) record_bytes_[0] ^= 0xFF;
  std::uint8_t* out = record_bytes_.data() + packet;
  for (std::uint32_t a = 0; a < ascans; ++a) {
    for (std::uint32_t s = 0; s < samples; ++s) {
      const std::uint16_t value = emulated_sample(counter + a, s, options_.info.adc_bits);
      *out++ = static_cast<std::uint8_t>(value);
      *out++ = static_cast<std::uint8_t>(value >> 8);
    }
  }
  record_position_ = 0;
  ++next_record_;
  ++records_sent_;
}

void EmulatedInstrument::fill_records(unsigned char* out, int length) {
  std::size_t left = static_cast<std::size_t>(length);
  while (left > 0) {
    if (record_position_ >= record_bytes_.size()) generate_record();
    const std::size_t n = std::min(left, record_bytes_.size() - record_position_);
    std::memcpy(out, record_bytes_.data() + record_position_, n);
    out += n;
    left -= n;
    record_position_ += n;
  }
}

// --- control requests ---

int EmulatedInstrument::run_control(unsigned char* buffer, int length) {
  const protocol::SetupPacket setup = protocol::decode_setup(buffer);
  unsigned char* data = buffer + kSetupBytes;
  ControlRequest logged{setup, {}};
  if ((setup.request_type & 0x80) == 0) logged.data.assign(data, data + setup.length);
  control_log_.push_back(logged);
  if (static_cast<int>(kSetupBytes + setup.length) > length) return -1;

  // Standard GET_DESCRIPTOR(string): language IDs and the serial number.
  if (setup.request_type == 0x80 && setup.request == 0x06 && (setup.value >> 8) == 0x03) {
    std::vector<std::uint8_t> text;
    const std::uint8_t index = static_cast<std::uint8_t>(setup.value);
    if (index == 0) {
      text = {4, 3, 0x09, 0x04};
    } else {
      const std::string s = index == 3 ? options_.serial : "ioct emulated instrument";
      text = {static_cast<std::uint8_t>(2 + 2 * s.size()), 3};
      for (char c : s) text.insert(text.end(), {static_cast<std::uint8_t>(c), 0});
    }
    const int n = std::min<int>(setup.length, static_cast<int>(text.size()));
    std::memcpy(data, text.data(), static_cast<std::size_t>(n));
    return n;
  }
  if ((setup.request_type & 0x60) != 0x40) return -1;  // not a vendor request: STALL

  using protocol::Request;
  const auto request = static_cast<Request>(setup.request);
  const auto param = static_cast<protocol::Param>(setup.value);
  switch (request) {
    case Request::get_info: {
      if (setup.length != protocol::kDeviceInfoBytes) return -1;
      const auto block = protocol::encode(options_.info);
      std::memcpy(data, block.data(), block.size());
      return static_cast<int>(block.size());
    }
    case Request::set_param:
      if (setup.length != 4 || setup.value < 0x01 || setup.value > 0x0A) return -1;
      params_[param] = get32(data);
      return 4;
    case Request::get_param: {
      if (setup.length != 4) return -1;
      const auto it = overrides_.find(param);
      put32(data, it != overrides_.end() ? it->second : params_[param]);
      return 4;
    }
    case Request::acq_arm:
      if (params_[protocol::Param::samples_per_ascan] == 0 ||
          params_[protocol::Param::ascans_per_bscan] == 0) {
        return -1;  // not configured: refuse
      }
      armed_ = true;
      acquiring_ = false;
      started_since_arm_ = false;
      next_record_ = 0;
      records_sent_ = 0;
      records_dropped_ = 0;
      record_bytes_.clear();
      record_position_ = 0;
      return 0;
    case Request::acq_start:
      if (!armed_) return -1;
      if (started_since_arm_) next_record_ += options_.restart_gap_records;
      started_since_arm_ = true;
      acquiring_ = true;
      return 0;
    case Request::acq_stop:
      acquiring_ = false;
      record_bytes_.clear();  // the partial record in the FIFO is flushed
      record_position_ = 0;
      return 0;
    case Request::galvo_start:
      galvo_streaming_ = true;
      dac_output_ = 0;
      dac_underruns_ = 0;
      return 0;
    case Request::galvo_park:
      galvo_streaming_ = false;
      dac_fifo_.clear();
      dac_output_ = 0;
      return 0;
    case Request::get_status: {
      if (setup.length != protocol::kStatusReportBytes) return -1;
      const auto report = protocol::encode(status_report());
      std::memcpy(data, report.data(), report.size());
      return static_cast<int>(report.size());
    }
  }
  return -1;
}

// --- status reports and the DAC clock ---

void EmulatedInstrument::tick_status(std::chrono::steady_clock::time_point now) {
  last_status_ = now;
  if (!galvo_streaming_) return;
  for (std::uint32_t i = 0; i < options_.dac_samples_per_ms; ++i) {
    if (dac_fifo_.empty()) {
      ++dac_underruns_;
      break;
    }
    dac_fifo_.pop_front();
    ++dac_output_;
  }
}

protocol::StatusReport EmulatedInstrument::status_report() const {
  protocol::StatusReport report;
  if (acquiring_) report.status |= protocol::kStatusAcquiring;
  if (galvo_streaming_) report.status |= protocol::kStatusGalvoStreaming;
  if (galvo_fault_) report.status |= protocol::kStatusGalvoFault;
  if (dac_underruns_ != 0) report.status |= protocol::kStatusGalvoUnderrun;
  if (records_dropped_ != 0) report.status |= protocol::kStatusRecordOverrun;
  report.sweep_counter = next_record_ * sweeps_per_bscan();
  report.dac_samples_output = dac_output_;
  report.dac_fifo_fill = static_cast<std::uint32_t>(dac_fifo_.size());
  report.dac_underruns = dac_underruns_;
  report.records_dropped = records_dropped_;
  return report;
}

}  // namespace ioct::hal::usb::test
