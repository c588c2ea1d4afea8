// One USB instrument: the libusb context and device handle that UsbDigitizer and UsbGalvoOutput
// share, the event thread that runs libusb's event handling (every transfer callback runs there),
// the vendor control requests of the protocol, the status endpoint, and hotplug.
//
// Threads: the event thread runs libusb's event handling in rounds of at most 20 ms. Transfer
// callbacks run under libusb's event lock (on the event thread, or on a thread that is waiting
// in a synchronous control request), and the streams' housekeeping (EventClient) runs under the
// same lock, so the event side of every stream is serialised. Other threads reach the event
// side only through atomics, the streams' lock-free queues, or run_on_event_thread() (set-up
// paths). Control requests are synchronous and are made from any thread but the event thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ioct/hal/usb/usb_instrument_config.hpp"
#include "ioct/hal/usb/usb_protocol.hpp"

struct libusb_context;
struct libusb_device;
struct libusb_device_handle;
struct libusb_transfer;

namespace ioct::hal::usb {

class UsbInstrument {
 public:
  // A stream whose housekeeping runs on the event thread after every round of event handling
  // (at least every 20 ms; each status report, every millisecond, ends a round), with libusb's
  // event lock held: serialised with its callbacks.
  class EventClient {
   public:
    virtual ~EventClient() = default;
    virtual void on_events_handled() noexcept = 0;
  };

  // Finds and opens the instrument, claims its interface, checks its endpoints and protocol
  // version, and starts the event thread and the status stream. Throws ConfigError for a bad
  // config and UsbError naming the instrument and what to do when it cannot be had.
  static std::shared_ptr<UsbInstrument> open(const UsbInstrumentConfig& config);
  ~UsbInstrument();
  UsbInstrument(const UsbInstrument&) = delete;
  UsbInstrument& operator=(const UsbInstrument&) = delete;

  const UsbInstrumentConfig& config() const noexcept { return config_; }
  // The instrument's GET_INFO block, read at the last (re)connection.
  const protocol::DeviceInfo& info() const noexcept { return info_; }
  // wMaxPacketSize of one of the protocol's endpoints.
  std::uint32_t max_packet_size(std::uint8_t endpoint) const noexcept;
  // "instrument 1209:0001 at bus 1 device 2", for messages.
  const std::string& description() const noexcept { return description_; }

  // Vendor control requests; block up to usb.control_timeout_ms and throw UsbError. Not from the
  // event thread.
  void send(protocol::Request request);
  void set_param(protocol::Param param, std::uint32_t value);
  std::uint32_t get_param(protocol::Param param);
  protocol::StatusReport read_status();
  // send() for the safety path: returns 0 or the LIBUSB_ERROR_* code, never throws.
  int try_send(protocol::Request request) noexcept;

  // The latest report from the status endpoint and how many have arrived since open().
  protocol::StatusReport latest_status() const noexcept;
  std::uint64_t status_reports() const noexcept {
    return status_reports_.load(std::memory_order_acquire);
  }

  // True from the moment the instrument went away (a transfer or request saw
  // LIBUSB_ERROR_NO_DEVICE, or hotplug reported it left) until reconnect().
  bool device_lost() const noexcept { return lost_.load(std::memory_order_acquire); }
  void mark_lost() noexcept { lost_.store(true, std::memory_order_release); }
  // Hotplug arrivals of a device with this vendor and product ID since open(): a reason to try
  // reconnect(). Stays 0 where libusb has no hotplug support.
  std::uint64_t arrivals() const noexcept { return arrivals_.load(std::memory_order_acquire); }
  // Increments with every reconnect(); streams re-apply their settings when it changed.
  std::uint64_t connection() const noexcept { return connection_.load(std::memory_order_acquire); }
  // After the instrument was lost: enumerates again, opens and claims the matching device and
  // restarts the status stream. The streams must be idle (stopped or parked). Throws UsbError
  // when no matching instrument is present.
  void reconnect();

  // --- for the streams ---
  libusb_context* context() const noexcept { return context_; }
  libusb_device_handle* handle() const noexcept { return handle_.load(std::memory_order_acquire); }
  void attach(EventClient* client);
  void detach(EventClient* client);
  // Runs `task` on the event thread, with the event lock held, and waits for it (runs it at
  // once when called on the event thread). For set-up paths: it locks and allocates.
  void run_on_event_thread(const std::function<void()>& task);
  // Makes the event thread return from its wait soon (takes a libusb mutex briefly).
  void wake_event_thread() noexcept;
  bool on_event_thread() const noexcept {
    return std::this_thread::get_id() == event_thread_id_.load(std::memory_order_acquire);
  }

 private:
  explicit UsbInstrument(const UsbInstrumentConfig& config);
  void connect();  // find, open, claim, check: sets handle_, info_, description_
  // The first device of `list` with the config's vendor and product ID (and serial, where one is
  // set) that opens: its handle, and the device in `device`; sets description_. Throws UsbError
  // when there is none.
  libusb_device_handle* open_matching_device(libusb_device** list, std::ptrdiff_t count,
                                             libusb_device*& device);
  // Sets the endpoints' packet sizes from the active configuration. Releases the claimed
  // interface before it throws UsbError (no configuration, or an endpoint of the protocol missing).
  void read_endpoint_sizes(libusb_device* device, libusb_device_handle* handle);
  // GET_INFO, checked for the protocol's magic and major version.
  protocol::DeviceInfo read_device_info();
  void disconnect() noexcept;
  void event_loop();
  void housekeeping();
  void start_status_stream();  // event thread
  void stop_status_stream() noexcept;
  static void status_transfer_done(libusb_transfer* transfer);
  void on_status_transfer(libusb_transfer* transfer) noexcept;
  static int hotplug_event(libusb_device* device, bool arrived, void* user_data) noexcept;
  // A control transfer on `handle`, asynchronous underneath: the event thread completes it and
  // the caller waits on a condition variable. (libusb's synchronous API is not used: its waiters
  // are woken only when the event lock is released, libusb issue #917.) Returns the bytes of the
  // data stage or a LIBUSB_ERROR_* code.
  int control_transfer(libusb_device_handle* handle, std::uint8_t request_type,
                       std::uint8_t request, std::uint16_t value, std::uint16_t index,
                       std::uint8_t* data, std::uint16_t length) noexcept;
  int control(std::uint8_t request_type, protocol::Request request, std::uint16_t value,
              std::uint8_t* data, std::uint16_t length) noexcept;
  std::string read_serial(libusb_device_handle* handle, std::uint8_t index) noexcept;
  static void control_transfer_done(libusb_transfer* transfer);
  void check_control(int result, std::string_view what, std::uint16_t expected_length);

  UsbInstrumentConfig config_;
  libusb_context* context_ = nullptr;
  std::atomic<libusb_device_handle*> handle_{nullptr};
  protocol::DeviceInfo info_;
  std::string description_;
  std::uint32_t record_packet_bytes_ = 0;
  std::uint32_t galvo_packet_bytes_ = 0;
  std::uint32_t status_packet_bytes_ = 0;

  // One control transfer at a time (set-up paths and park()).
  std::mutex control_mutex_;
  libusb_transfer* control_ = nullptr;
  std::unique_ptr<std::uint8_t[]> control_buffer_;
  std::mutex control_done_mutex_;
  std::condition_variable control_done_cv_;
  bool control_done_ = false;

  std::thread event_thread_;
  std::atomic<std::thread::id> event_thread_id_{};
  std::atomic<bool> quit_{false};

  std::mutex clients_mutex_;  // taken by the event thread and set-up paths only
  std::vector<EventClient*> clients_;

  struct Task {
    const std::function<void()>* function = nullptr;
    bool done = false;
    std::exception_ptr failure;
  };
  std::mutex tasks_mutex_;
  std::condition_variable task_done_;
  std::vector<Task*> tasks_;

  // Status stream (event side): two interrupt transfers kept queued on the status endpoint.
  std::vector<libusb_transfer*> status_transfers_;
  std::vector<std::unique_ptr<std::uint8_t[]>> status_buffers_;
  std::atomic<int> status_in_flight_{0};
  bool status_streaming_ = false;  // event side
  std::uint32_t status_errors_in_a_row_ = 0;
  // The latest report, behind a sequence lock (one writer: the event thread).
  std::atomic<std::uint64_t> status_sequence_{0};
  std::atomic<std::uint64_t> status_words_[6]{};
  std::atomic<std::uint64_t> status_reports_{0};

  std::atomic<bool> lost_{false};
  std::atomic<std::uint64_t> arrivals_{0};
  std::atomic<std::uint64_t> connection_{0};
  int hotplug_handle_ = 0;
  bool hotplug_registered_ = false;
};

}  // namespace ioct::hal::usb
