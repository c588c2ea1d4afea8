#include "ioct/hal/usb/usb_instrument.hpp"

#include <libusb.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>

#include "ioct/hal/usb/usb_error.hpp"

namespace ioct::hal::usb {
namespace {

constexpr int kStatusTransfers = 2;
constexpr std::uint32_t kStatusErrorsBeforeGivingUp = 100;
constexpr std::chrono::milliseconds kEventWait{20};
constexpr std::chrono::milliseconds kCancelWait{1000};
constexpr std::uint16_t kMaxControlData = 255;

std::string hex4(std::uint16_t value) {
  char text[8];
  std::snprintf(text, sizeof(text), "%04x", value);
  return text;
}

std::string identity(const UsbInstrumentConfig& config) {
  return hex4(config.vendor_id) + ":" + hex4(config.product_id);
}

// Why no matching instrument could be had: the last one that would not open, else the keys that
// select it (and the serials present when a serial was asked for).
UsbError no_instrument_error(const UsbInstrumentConfig& config, int open_error,
                             const std::string& open_error_where,
                             const std::vector<std::string>& other_serials) {
  if (open_error != 0) {
    return UsbError(describe_usb_failure("usb: cannot open instrument " + identity(config) +
                                             " at " + open_error_where,
                                         open_error),
                    open_error);
  }
  std::string text =
      "usb: no instrument " + identity(config) + " is connected (usb.vendor_id, usb.product_id";
  if (!config.serial.empty()) {
    text += ", usb.serial = \"" + config.serial + "\"; serials present:";
    for (const std::string& s : other_serials) text += " " + s;
    if (other_serials.empty()) text += " none";
  }
  text += ")";
  return UsbError(text, LIBUSB_ERROR_NOT_FOUND);
}

// wMaxPacketSize of the protocol's endpoints on interface 0 (alternate setting 0); 0 where one is
// missing or has another transfer type.
struct EndpointSizes {
  std::uint32_t record = 0;
  std::uint32_t galvo = 0;
  std::uint32_t status = 0;
};

EndpointSizes protocol_endpoint_sizes(const libusb_config_descriptor& configuration) {
  EndpointSizes sizes;
  for (std::uint8_t i = 0; i < configuration.bNumInterfaces; ++i) {
    const libusb_interface& interface = configuration.interface[i];
    if (interface.num_altsetting < 1) continue;
    const libusb_interface_descriptor& setting = interface.altsetting[0];
    if (setting.bInterfaceNumber != protocol::kInterfaceNumber) continue;
    for (std::uint8_t e = 0; e < setting.bNumEndpoints; ++e) {
      const libusb_endpoint_descriptor& endpoint = setting.endpoint[e];
      const auto type = endpoint.bmAttributes & LIBUSB_TRANSFER_TYPE_MASK;
      const std::uint32_t size = endpoint.wMaxPacketSize & 0x7FFu;
      if (endpoint.bEndpointAddress == protocol::kRecordEndpoint &&
          type == LIBUSB_TRANSFER_TYPE_BULK) {
        sizes.record = size;
      } else if (endpoint.bEndpointAddress == protocol::kGalvoEndpoint &&
                 type == LIBUSB_TRANSFER_TYPE_BULK) {
        sizes.galvo = size;
      } else if (endpoint.bEndpointAddress == protocol::kStatusEndpoint &&
                 type == LIBUSB_TRANSFER_TYPE_INTERRUPT) {
        sizes.status = size;
      }
    }
  }
  return sizes;
}

// Waits until `count` reaches 0, at most `limit`; for cancellations, which complete on the
// event thread.
bool wait_for_zero(const std::atomic<int>& count, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (count.load(std::memory_order_acquire) != 0) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

}  // namespace

UsbInstrument::UsbInstrument(const UsbInstrumentConfig& config) : config_(config) {}

std::shared_ptr<UsbInstrument> UsbInstrument::open(const UsbInstrumentConfig& config) {
  config.validate();
  std::shared_ptr<UsbInstrument> instrument(new UsbInstrument(config));
  if (const int r = libusb_init(&instrument->context_); r != 0) {
    instrument->context_ = nullptr;
    throw UsbError(describe_usb_failure("usb: cannot initialise libusb", r), r);
  }
  instrument->control_ = libusb_alloc_transfer(0);
  if (instrument->control_ == nullptr) throw std::bad_alloc();
  instrument->control_buffer_ =
      std::make_unique<std::uint8_t[]>(LIBUSB_CONTROL_SETUP_SIZE + kMaxControlData);
  UsbInstrument* self = instrument.get();
  // Control transfers complete on the event thread, so it runs before the first one.
  instrument->event_thread_ = std::thread([self] { self->event_loop(); });
  instrument->connect();

  instrument->status_buffers_.resize(kStatusTransfers);
  for (int i = 0; i < kStatusTransfers; ++i) {
    libusb_transfer* transfer = libusb_alloc_transfer(0);
    if (transfer == nullptr) throw std::bad_alloc();
    instrument->status_transfers_.push_back(transfer);
    instrument->status_buffers_[static_cast<std::size_t>(i)] =
        std::make_unique<std::uint8_t[]>(instrument->status_packet_bytes_);
  }
  instrument->run_on_event_thread([self] { self->start_status_stream(); });

  if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) != 0) {
    auto trampoline = [](libusb_context*, libusb_device* device, libusb_hotplug_event event,
                         void* user_data) -> int {
      return hotplug_event(device, event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED, user_data);
    };
    const int r = libusb_hotplug_register_callback(
        instrument->context_,
        static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED |
                                          LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
        static_cast<libusb_hotplug_flag>(0), config.vendor_id, config.product_id,
        LIBUSB_HOTPLUG_MATCH_ANY, trampoline, self, &instrument->hotplug_handle_);
    instrument->hotplug_registered_ = (r == LIBUSB_SUCCESS);
  }
  return instrument;
}

UsbInstrument::~UsbInstrument() {
  if (hotplug_registered_) libusb_hotplug_deregister_callback(context_, hotplug_handle_);
  if (event_thread_.joinable()) {
    run_on_event_thread([this] { stop_status_stream(); });
    wait_for_zero(status_in_flight_, kCancelWait);
    quit_.store(true, std::memory_order_release);
    wake_event_thread();
    event_thread_.join();
  }
  disconnect();
  if (status_in_flight_.load() == 0) {
    for (libusb_transfer* transfer : status_transfers_) libusb_free_transfer(transfer);
  }
  libusb_free_transfer(control_);  // never in flight here: control requests wait for it
  if (context_ != nullptr) libusb_exit(context_);
}

void UsbInstrument::connect() {
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(context_, &list);
  if (count < 0) {
    const int r = static_cast<int>(count);
    throw UsbError(describe_usb_failure("usb: cannot list the USB devices", r), r);
  }
  struct ListGuard {
    libusb_device** list;
    ~ListGuard() { libusb_free_device_list(list, 1); }
  } guard{list};

  libusb_device* device = nullptr;
  libusb_device_handle* handle = open_matching_device(list, count, device);
  struct HandleGuard {
    libusb_device_handle* handle;
    ~HandleGuard() {
      if (handle != nullptr) libusb_close(handle);
    }
  } handle_guard{handle};

  libusb_set_auto_detach_kernel_driver(handle, 1);  // unsupported: nothing to detach
  if (const int r = libusb_claim_interface(handle, protocol::kInterfaceNumber); r != 0) {
    throw UsbError(describe_usb_failure("usb: cannot claim interface 0 of " + description_, r), r);
  }
  read_endpoint_sizes(device, handle);

  // From here disconnect() releases the interface and closes the handle.
  handle_.store(handle, std::memory_order_release);
  handle_guard.handle = nullptr;
  try {
    info_ = read_device_info();
  } catch (...) {
    disconnect();
    throw;
  }
}

libusb_device_handle* UsbInstrument::open_matching_device(libusb_device** list,
                                                          std::ptrdiff_t count,
                                                          libusb_device*& device) {
  int open_error = 0;
  std::string open_error_where;
  std::vector<std::string> other_serials;
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(list[i], &descriptor) != 0) continue;
    if (descriptor.idVendor != config_.vendor_id || descriptor.idProduct != config_.product_id) {
      continue;
    }
    const std::string where = "bus " + std::to_string(libusb_get_bus_number(list[i])) + " device " +
                              std::to_string(libusb_get_device_address(list[i]));
    libusb_device_handle* candidate = nullptr;
    if (const int r = libusb_open(list[i], &candidate); r != 0) {
      open_error = r;
      open_error_where = where;
      continue;
    }
    if (!config_.serial.empty()) {
      const std::string found = read_serial(candidate, descriptor.iSerialNumber);
      if (found != config_.serial) {
        other_serials.push_back(found.empty() ? "(none)" : found);
        libusb_close(candidate);
        continue;
      }
    }
    device = list[i];
    description_ = "instrument " + identity(config_) + " at " + where +
                   (config_.serial.empty() ? "" : " serial " + config_.serial);
    return candidate;
  }
  throw no_instrument_error(config_, open_error, open_error_where, other_serials);
}

void UsbInstrument::read_endpoint_sizes(libusb_device* device, libusb_device_handle* handle) {
  libusb_config_descriptor* configuration = nullptr;
  if (const int r = libusb_get_active_config_descriptor(device, &configuration); r != 0) {
    libusb_release_interface(handle, protocol::kInterfaceNumber);
    throw UsbError(describe_usb_failure("usb: cannot read the configuration of " + description_, r),
                   r);
  }
  const EndpointSizes sizes = protocol_endpoint_sizes(*configuration);
  libusb_free_config_descriptor(configuration);
  record_packet_bytes_ = sizes.record;
  galvo_packet_bytes_ = sizes.galvo;
  status_packet_bytes_ = sizes.status;
  const char* missing = record_packet_bytes_ == 0   ? "bulk IN endpoint 0x81"
                        : galvo_packet_bytes_ == 0  ? "bulk OUT endpoint 0x02"
                        : status_packet_bytes_ == 0 ? "interrupt IN endpoint 0x83"
                                                    : nullptr;
  if (missing != nullptr) {
    libusb_release_interface(handle, protocol::kInterfaceNumber);
    throw UsbError("usb: " + description_ + " has no " + missing +
                       " on interface 0: its firmware does not speak the ioct USB protocol "
                       "(docs/usb-protocol.md)",
                   0);
  }
  status_packet_bytes_ =
      std::max<std::uint32_t>(status_packet_bytes_, protocol::kStatusReportBytes);
}

protocol::DeviceInfo UsbInstrument::read_device_info() {
  std::uint8_t block[protocol::kDeviceInfoBytes] = {};
  const int r =
      control(protocol::kRequestTypeIn, protocol::Request::get_info, 0, block, sizeof(block));
  check_control(r, "GET_INFO", sizeof(block));
  protocol::DeviceInfo info;
  if (!protocol::decode(block, info)) {
    throw UsbError("usb: " + description_ +
                       " answered GET_INFO without the protocol's magic: its firmware does not "
                       "speak the ioct USB protocol (docs/usb-protocol.md)",
                   0);
  }
  if (info.protocol_major != protocol::kProtocolMajor) {
    throw UsbError("usb: " + description_ + " speaks protocol " +
                       std::to_string(info.protocol_major) + "." +
                       std::to_string(info.protocol_minor) + "; this host speaks " +
                       std::to_string(protocol::kProtocolMajor) + ".x (docs/usb-protocol.md)",
                   0);
  }
  return info;
}

void UsbInstrument::disconnect() noexcept {
  libusb_device_handle* handle = handle_.exchange(nullptr, std::memory_order_acq_rel);
  if (handle == nullptr) return;
  libusb_release_interface(handle, protocol::kInterfaceNumber);  // fails harmlessly when gone
  libusb_close(handle);
}

std::uint32_t UsbInstrument::max_packet_size(std::uint8_t endpoint) const noexcept {
  switch (endpoint) {
    case protocol::kRecordEndpoint:
      return record_packet_bytes_;
    case protocol::kGalvoEndpoint:
      return galvo_packet_bytes_;
    case protocol::kStatusEndpoint:
      return status_packet_bytes_;
    default:
      return 0;
  }
}

void UsbInstrument::reconnect() {
  run_on_event_thread([this] { stop_status_stream(); });
  wait_for_zero(status_in_flight_, kCancelWait);
  disconnect();
  connect();
  lost_.store(false, std::memory_order_release);
  connection_.fetch_add(1, std::memory_order_acq_rel);
  run_on_event_thread([this] { start_status_stream(); });
}

// --- control requests ---

void UsbInstrument::control_transfer_done(libusb_transfer* transfer) {
  auto* self = static_cast<UsbInstrument*>(transfer->user_data);
  {
    std::lock_guard lock(self->control_done_mutex_);
    self->control_done_ = true;
  }
  self->control_done_cv_.notify_all();
}

int UsbInstrument::control_transfer(libusb_device_handle* handle, std::uint8_t request_type,
                                    std::uint8_t request, std::uint16_t value, std::uint16_t index,
                                    std::uint8_t* data, std::uint16_t length) noexcept {
  if (handle == nullptr) return LIBUSB_ERROR_NO_DEVICE;
  if (length > kMaxControlData) return LIBUSB_ERROR_INVALID_PARAM;
  if (on_event_thread()) return LIBUSB_ERROR_BUSY;  // it would wait for itself
  std::lock_guard serial(control_mutex_);
  std::uint8_t* buffer = control_buffer_.get();
  libusb_fill_control_setup(buffer, request_type, request, value, index, length);
  const bool in = (request_type & LIBUSB_ENDPOINT_IN) != 0;
  if (!in && length != 0) std::memcpy(buffer + LIBUSB_CONTROL_SETUP_SIZE, data, length);
  libusb_fill_control_transfer(control_, handle, buffer, control_transfer_done, this,
                               config_.control_timeout_ms);
  {
    std::lock_guard lock(control_done_mutex_);
    control_done_ = false;
  }
  if (const int r = libusb_submit_transfer(control_); r != 0) return r;
  {
    std::unique_lock lock(control_done_mutex_);
    // libusb times the transfer out after control_timeout_ms; the extra wait only guards
    // against an event thread that stopped handling events.
    const auto limit = std::chrono::milliseconds(config_.control_timeout_ms) + kCancelWait;
    if (!control_done_cv_.wait_for(lock, limit, [&] { return control_done_; })) {
      lock.unlock();
      libusb_cancel_transfer(control_);
      lock.lock();
      control_done_cv_.wait(lock, [&] { return control_done_; });
    }
  }
  switch (control_->status) {
    case LIBUSB_TRANSFER_COMPLETED:
      if (in && control_->actual_length > 0) {
        std::memcpy(data, libusb_control_transfer_get_data(control_),
                    static_cast<std::size_t>(control_->actual_length));
      }
      return control_->actual_length;
    case LIBUSB_TRANSFER_TIMED_OUT:
      return LIBUSB_ERROR_TIMEOUT;
    case LIBUSB_TRANSFER_STALL:
      return LIBUSB_ERROR_PIPE;
    case LIBUSB_TRANSFER_NO_DEVICE:
      return LIBUSB_ERROR_NO_DEVICE;
    case LIBUSB_TRANSFER_OVERFLOW:
      return LIBUSB_ERROR_OVERFLOW;
    case LIBUSB_TRANSFER_CANCELLED:
      return LIBUSB_ERROR_TIMEOUT;
    default:
      return LIBUSB_ERROR_IO;
  }
}

int UsbInstrument::control(std::uint8_t request_type, protocol::Request request,
                           std::uint16_t value, std::uint8_t* data, std::uint16_t length) noexcept {
  const int r = control_transfer(handle_.load(std::memory_order_acquire), request_type,
                                 static_cast<std::uint8_t>(request), value,
                                 protocol::kInterfaceNumber, data, length);
  if (r == LIBUSB_ERROR_NO_DEVICE) mark_lost();
  return r;
}

std::string UsbInstrument::read_serial(libusb_device_handle* handle, std::uint8_t index) noexcept {
  if (index == 0) return "";
  // Standard GET_DESCRIPTOR(string): first the language IDs, then the string in the first.
  std::uint8_t languages[4] = {};
  const std::uint8_t request_type = LIBUSB_ENDPOINT_IN;
  if (control_transfer(handle, request_type, LIBUSB_REQUEST_GET_DESCRIPTOR, LIBUSB_DT_STRING << 8,
                       0, languages, sizeof(languages)) < 4) {
    return "";
  }
  const auto language = static_cast<std::uint16_t>(languages[2] | (languages[3] << 8));
  std::uint8_t text[255] = {};
  const int n = control_transfer(handle, request_type, LIBUSB_REQUEST_GET_DESCRIPTOR,
                                 static_cast<std::uint16_t>((LIBUSB_DT_STRING << 8) | index),
                                 language, text, sizeof(text));
  if (n < 2 || text[1] != LIBUSB_DT_STRING) return "";
  std::string serial;
  for (int i = 2; i + 1 < std::min<int>(n, text[0]); i += 2) {
    serial += text[i + 1] == 0 && text[i] < 0x80 ? static_cast<char>(text[i]) : '?';
  }
  return serial;
}

void UsbInstrument::check_control(int result, std::string_view what,
                                  std::uint16_t expected_length) {
  if (result < 0) {
    std::string text = describe_usb_failure(
        "usb: " + std::string(what) + " to " + description_ + " failed", result);
    if (result == LIBUSB_ERROR_PIPE) text += "; the instrument refused the request (STALL)";
    throw UsbError(text, result);
  }
  if (result != expected_length) {
    throw UsbError("usb: " + std::string(what) + " to " + description_ + " moved " +
                       std::to_string(result) + " bytes; the protocol needs " +
                       std::to_string(expected_length),
                   0);
  }
}

void UsbInstrument::send(protocol::Request request) {
  check_control(control(protocol::kRequestTypeOut, request, 0, nullptr, 0),
                protocol::to_string(request), 0);
}

int UsbInstrument::try_send(protocol::Request request) noexcept {
  const int r = control(protocol::kRequestTypeOut, request, 0, nullptr, 0);
  return r < 0 ? r : 0;
}

void UsbInstrument::set_param(protocol::Param param, std::uint32_t value) {
  std::uint8_t data[4];
  for (int i = 0; i < 4; ++i) data[i] = static_cast<std::uint8_t>(value >> (8 * i));
  check_control(control(protocol::kRequestTypeOut, protocol::Request::set_param,
                        static_cast<std::uint16_t>(param), data, sizeof(data)),
                "SET_PARAM " + std::string(protocol::to_string(param)), sizeof(data));
}

std::uint32_t UsbInstrument::get_param(protocol::Param param) {
  std::uint8_t data[4] = {};
  check_control(control(protocol::kRequestTypeIn, protocol::Request::get_param,
                        static_cast<std::uint16_t>(param), data, sizeof(data)),
                "GET_PARAM " + std::string(protocol::to_string(param)), sizeof(data));
  return static_cast<std::uint32_t>(data[0] | (data[1] << 8) | (data[2] << 16)) |
         (static_cast<std::uint32_t>(data[3]) << 24);
}

protocol::StatusReport UsbInstrument::read_status() {
  std::uint8_t block[protocol::kStatusReportBytes] = {};
  check_control(
      control(protocol::kRequestTypeIn, protocol::Request::get_status, 0, block, sizeof(block)),
      "GET_STATUS", sizeof(block));
  protocol::StatusReport report;
  if (!protocol::decode(block, report)) {
    throw UsbError("usb: " + description_ + " answered GET_STATUS without the status magic", 0);
  }
  return report;
}

// --- event thread ---

void UsbInstrument::event_loop() {
  event_thread_id_.store(std::this_thread::get_id(), std::memory_order_release);
  const auto wait_us = std::chrono::duration_cast<std::chrono::microseconds>(kEventWait).count();
  while (!quit_.load(std::memory_order_acquire)) {
    // Handle one round of events, then give the event lock back: libusb wakes threads waiting
    // in a synchronous transfer only when the lock is released, not when their transfer
    // completes (libusb issue #917), so holding it for long would stall control requests.
    timeval wait{0, static_cast<suseconds_t>(wait_us)};
    libusb_handle_events_timeout_completed(context_, &wait, nullptr);
    // Callbacks run under the event lock, on whichever thread handles events: taking it keeps
    // the streams' housekeeping serialised with them.
    libusb_lock_events(context_);
    housekeeping();
    libusb_unlock_events(context_);
  }
  event_thread_id_.store(std::thread::id{}, std::memory_order_release);
}

void UsbInstrument::housekeeping() {
  for (;;) {
    Task* task = nullptr;
    {
      std::lock_guard lock(tasks_mutex_);
      if (tasks_.empty()) break;
      task = tasks_.front();
      tasks_.erase(tasks_.begin());
    }
    std::exception_ptr failure;
    try {
      (*task->function)();
    } catch (...) {
      failure = std::current_exception();
    }
    {
      std::lock_guard lock(tasks_mutex_);
      task->failure = failure;
      task->done = true;
    }
    task_done_.notify_all();
  }
  std::lock_guard lock(clients_mutex_);
  for (EventClient* client : clients_) client->on_events_handled();
}

void UsbInstrument::run_on_event_thread(const std::function<void()>& task) {
  if (on_event_thread() || !event_thread_.joinable() || quit_.load()) {
    task();
    return;
  }
  Task pending;
  pending.function = &task;
  {
    std::lock_guard lock(tasks_mutex_);
    tasks_.push_back(&pending);
  }
  wake_event_thread();
  std::unique_lock lock(tasks_mutex_);
  task_done_.wait(lock, [&] { return pending.done; });
  if (pending.failure) std::rethrow_exception(pending.failure);
}

void UsbInstrument::wake_event_thread() noexcept {
  if (context_ != nullptr) libusb_interrupt_event_handler(context_);
}

void UsbInstrument::attach(EventClient* client) {
  std::lock_guard lock(clients_mutex_);
  clients_.push_back(client);
}

void UsbInstrument::detach(EventClient* client) {
  std::lock_guard lock(clients_mutex_);
  clients_.erase(std::remove(clients_.begin(), clients_.end(), client), clients_.end());
}

// --- status stream (event thread) ---

void UsbInstrument::start_status_stream() {
  status_streaming_ = true;
  status_errors_in_a_row_ = 0;
  for (std::size_t i = 0; i < status_transfers_.size(); ++i) {
    libusb_transfer* transfer = status_transfers_[i];
    libusb_fill_interrupt_transfer(transfer, handle(), protocol::kStatusEndpoint,
                                   status_buffers_[i].get(), static_cast<int>(status_packet_bytes_),
                                   status_transfer_done, this, 0);
    const int r = libusb_submit_transfer(transfer);
    if (r == 0) {
      status_in_flight_.fetch_add(1, std::memory_order_acq_rel);
    } else if (r == LIBUSB_ERROR_NO_DEVICE) {
      mark_lost();
    }
  }
}

void UsbInstrument::stop_status_stream() noexcept {
  status_streaming_ = false;
  for (libusb_transfer* transfer : status_transfers_) libusb_cancel_transfer(transfer);
}

void UsbInstrument::status_transfer_done(libusb_transfer* transfer) {
  static_cast<UsbInstrument*>(transfer->user_data)->on_status_transfer(transfer);
}

void UsbInstrument::on_status_transfer(libusb_transfer* transfer) noexcept {
  status_in_flight_.fetch_sub(1, std::memory_order_acq_rel);
  if (!status_streaming_) return;
  switch (transfer->status) {
    case LIBUSB_TRANSFER_COMPLETED: {
      protocol::StatusReport report;
      if (protocol::decode({transfer->buffer, static_cast<std::size_t>(transfer->actual_length)},
                           report)) {
        const std::uint64_t words[6] = {
            report.status,        report.sweep_counter, report.dac_samples_output,
            report.dac_fifo_fill, report.dac_underruns, report.records_dropped};
        // Sequence lock without fences: a reader that sees any new word also sees the odd
        // sequence stored before it (release/acquire on the words themselves).
        const std::uint64_t sequence = status_sequence_.load(std::memory_order_relaxed);
        status_sequence_.store(sequence + 1, std::memory_order_relaxed);
        for (int i = 0; i < 6; ++i) status_words_[i].store(words[i], std::memory_order_release);
        status_sequence_.store(sequence + 2, std::memory_order_release);
        status_reports_.fetch_add(1, std::memory_order_acq_rel);
      }
      status_errors_in_a_row_ = 0;
      break;
    }
    case LIBUSB_TRANSFER_NO_DEVICE:
      mark_lost();
      return;
    case LIBUSB_TRANSFER_CANCELLED:
      return;
    case LIBUSB_TRANSFER_STALL:
      libusb_clear_halt(transfer->dev_handle, protocol::kStatusEndpoint);
      [[fallthrough]];
    default:
      if (++status_errors_in_a_row_ >= kStatusErrorsBeforeGivingUp) return;
      break;
  }
  transfer->dev_handle = handle();
  const int r = libusb_submit_transfer(transfer);
  if (r == 0) {
    status_in_flight_.fetch_add(1, std::memory_order_acq_rel);
  } else if (r == LIBUSB_ERROR_NO_DEVICE) {
    mark_lost();
  }
}

protocol::StatusReport UsbInstrument::latest_status() const noexcept {
  std::uint64_t words[6];
  for (;;) {
    const std::uint64_t before = status_sequence_.load(std::memory_order_acquire);
    for (int i = 0; i < 6; ++i) words[i] = status_words_[i].load(std::memory_order_acquire);
    if ((before & 1u) == 0 && status_sequence_.load(std::memory_order_relaxed) == before) break;
  }
  protocol::StatusReport report;
  report.status = static_cast<std::uint32_t>(words[0]);
  report.sweep_counter = words[1];
  report.dac_samples_output = words[2];
  report.dac_fifo_fill = static_cast<std::uint32_t>(words[3]);
  report.dac_underruns = static_cast<std::uint32_t>(words[4]);
  report.records_dropped = static_cast<std::uint32_t>(words[5]);
  return report;
}

int UsbInstrument::hotplug_event(libusb_device* device, bool arrived, void* user_data) noexcept {
  auto* self = static_cast<UsbInstrument*>(user_data);
  if (arrived) {
    self->arrivals_.fetch_add(1, std::memory_order_acq_rel);
  } else if (libusb_device_handle* handle = self->handle();
             handle != nullptr && libusb_get_device(handle) == device) {
    self->mark_lost();
  }
  return 0;  // stay registered
}

}  // namespace ioct::hal::usb
