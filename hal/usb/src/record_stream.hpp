// The bulk IN record stream behind UsbDigitizer: a pool of libusb transfers kept queued on the
// record endpoint and resubmitted from their completion callbacks, cut by a RecordPlan.
//
// Two sides:
//  - the event side (callbacks and on_events_handled(), serialised on the instrument's event
//    thread) submits the plan's parts in order. A body part whose group's slot has been handed
//    over lands straight in the slot; every other part (headers, tails, body parts of a group
//    whose slot is not known yet) lands in a staging buffer. Each completed part is queued for
//    the real-time side in order.
//  - the real-time side (UsbDigitizer::acquire_group) hands over a slot, takes the completions
//    in order, copies staged data into the slot, and hands staging buffers back. It talks to the
//    event side only through atomics, two lock-free rings and a futex word, and calls into
//    libusb only on rare paths (the event side starved, a fault).
// A fault (timeout, transfer error, bad record) makes the real-time side ask for a resync: the
// event side cancels every transfer, acknowledges (from then on no transfer points into the
// slot), then stops and restarts the instrument's stream with asynchronous control requests and
// resumes under a new epoch; completions of older epochs are dropped.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "ioct/concurrency/spsc_queue.hpp"
#include "ioct/hal/usb/record_plan.hpp"
#include "ioct/hal/usb/usb_instrument.hpp"
#include "progress_signal.hpp"

struct libusb_transfer;

namespace ioct::hal::usb::detail {

inline constexpr std::int32_t kNoStaging = -1;
inline constexpr std::int32_t kPartCompleted = 0;  // Completion::status; else libusb's status
inline constexpr std::int32_t kPartShort = 100;    // completed with fewer bytes than asked

struct Completion {
  std::uint64_t epoch = 0;
  std::uint64_t group = 0;
  std::uint32_t part = 0;
  std::int32_t staging = kNoStaging;     // the buffer holding the data, or kNoStaging (in the slot)
  std::int32_t status = kPartCompleted;  // a libusb_transfer_status when not completed
  std::uint32_t actual = 0;              // bytes received
};

class RecordStream final : public UsbInstrument::EventClient {
 public:
  explicit RecordStream(UsbInstrument& instrument);
  ~RecordStream() override;
  RecordStream(const RecordStream&) = delete;
  RecordStream& operator=(const RecordStream&) = delete;

  // --- set-up side (not while streaming) ---
  // Allocates transfers, staging buffers and rings for `plan`.
  void configure(const RecordPlan& plan, const UsbInstrumentConfig& config);
  // Queues the first transfers for group 0 under a fresh epoch, which it returns. Throws
  // UsbError when the transfers cannot be queued (LIBUSB_ERROR_NO_MEM names the usbfs limit).
  std::uint64_t start();
  // Cancels every transfer and waits until none is in flight (bounded); the stream is stopped.
  void halt() noexcept;

  // --- real-time side ---
  // Hands over the slot of `group`: body parts submitted from now on land in it directly.
  void publish_slot(std::uint64_t group, std::uint8_t* slot) noexcept;
  bool pop(Completion& completion) noexcept { return completions_->pop(completion); }
  // Completions are queued without a wake-up when they need no work (a body part in the slot).
  bool has_completions() const noexcept { return !completions_->empty(); }
  const std::uint8_t* staging(std::int32_t id) const noexcept {
    return staging_memory_.get() + static_cast<std::size_t>(id) * staging_bytes_;
  }
  void release(std::int32_t id) noexcept;
  ProgressSignal& progress() noexcept { return progress_; }
  bool lost() const noexcept { return lost_.load(std::memory_order_acquire); }
  int in_flight() const noexcept { return in_flight_.load(std::memory_order_acquire); }
  // Asks the event side to drop everything and go on with group `next_group` under `epoch`;
  // returns once no transfer is in flight, false when that did not happen by `deadline_ns`.
  bool resync(std::uint64_t epoch, std::uint64_t next_group, std::uint64_t deadline_ns) noexcept;
  // Waits until no transfer is in flight (after the device was lost); false at the deadline.
  bool wait_idle(std::uint64_t deadline_ns) noexcept;

  // Diagnostics, any thread.
  int last_submit_error() const noexcept {
    return last_submit_error_.load(std::memory_order_relaxed);
  }
  std::uint64_t submit_failures() const noexcept {
    return submit_failures_.load(std::memory_order_relaxed);
  }
  std::uint64_t starvations() const noexcept {
    return starvations_.load(std::memory_order_relaxed);
  }
  std::uint64_t bytes_in_flight_limit() const noexcept {
    return std::uint64_t{transfer_count_} * plan_.chunk_bytes;
  }

  void on_events_handled() noexcept override;

 private:
  enum class Phase : std::uint8_t { stopped, streaming, halted, cancelling, restarting, lost };
  struct Transfer {
    RecordStream* stream = nullptr;
    libusb_transfer* transfer = nullptr;
    std::uint64_t epoch = 0;
    std::uint64_t group = 0;
    std::uint32_t part = 0;
    std::int32_t staging = kNoStaging;
    std::uint32_t index = 0;
  };

  // Event side.
  void pump() noexcept;
  static void transfer_done(libusb_transfer* transfer);
  static void control_done(libusb_transfer* transfer);
  void on_transfer_done(Transfer& transfer) noexcept;
  void on_control_done() noexcept;
  void begin_cancel(Phase after) noexcept;
  void finish_cancel() noexcept;
  void enter_lost() noexcept;
  void send_control(std::uint8_t request) noexcept;
  void acknowledge() noexcept;
  void free_staging(std::int32_t id) noexcept;
  void free_transfers() noexcept;

  UsbInstrument& instrument_;
  RecordPlan plan_;
  std::uint32_t transfer_count_ = 0;
  std::uint32_t staging_count_ = 0;
  std::size_t staging_bytes_ = 0;
  std::uint32_t control_timeout_ms_ = 1000;

  struct FreeDeleter {
    void operator()(std::uint8_t* p) const noexcept;
  };
  std::unique_ptr<std::uint8_t[], FreeDeleter> staging_memory_;
  std::vector<Transfer> transfers_;
  libusb_transfer* control_ = nullptr;
  std::unique_ptr<std::uint8_t[]> control_buffer_;

  // Event side only.
  Phase phase_ = Phase::stopped;
  Phase after_cancel_ = Phase::stopped;
  std::uint64_t epoch_ = 0;
  std::uint64_t cursor_group_ = 0;
  std::uint64_t cursor_part_ = 0;
  std::uint64_t target_epoch_ = 0;
  std::uint64_t target_group_ = 0;
  std::vector<std::uint32_t> idle_transfers_;
  std::vector<std::int32_t> free_staging_;
  int control_step_ = 0;
  bool restart_pending_ = false;

  // Shared.
  // Event side -> real-time side, and back; made anew by configure() (a queue never changes
  // size), while neither side uses them.
  std::unique_ptr<SpscQueue<Completion>> completions_ = std::make_unique<SpscQueue<Completion>>(1);
  std::unique_ptr<SpscQueue<std::int32_t>> released_staging_ =
      std::make_unique<SpscQueue<std::int32_t>>(1);
  ProgressSignal progress_;
  std::atomic<std::uint64_t> published_group_{~std::uint64_t{0}};
  std::atomic<std::uint8_t*> published_slot_{nullptr};
  std::atomic<std::uint64_t> resync_epoch_{0};
  std::atomic<std::uint64_t> resync_group_{0};
  std::atomic<std::uint64_t> acknowledged_epoch_{0};
  std::atomic<bool> starved_{false};
  std::atomic<bool> lost_{false};
  std::atomic<bool> control_busy_{false};
  std::atomic<int> in_flight_{0};
  std::atomic<int> last_submit_error_{0};
  std::atomic<std::uint64_t> submit_failures_{0};
  std::atomic<std::uint64_t> starvations_{0};
};

}  // namespace ioct::hal::usb::detail
