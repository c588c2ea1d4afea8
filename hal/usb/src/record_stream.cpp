#include "record_stream.hpp"

#include <libusb.h>

#include <chrono>
#include <cstdlib>
#include <new>
#include <string>
#include <thread>

#include "ioct/hal/usb/usb_error.hpp"

namespace ioct::hal::usb::detail {
namespace {

constexpr std::uint64_t kHaltWaitNs = 1'000'000'000;  // cancellations complete in microseconds

}  // namespace

void RecordStream::FreeDeleter::operator()(std::uint8_t* p) const noexcept {
  std::free(p);
}

RecordStream::RecordStream(UsbInstrument& instrument) : instrument_(instrument) {
  instrument_.attach(this);
}

RecordStream::~RecordStream() {
  halt();
  instrument_.detach(this);
  free_transfers();
}

void RecordStream::free_transfers() noexcept {
  // Never free a transfer libusb still owns.
  if (in_flight_.load() != 0 || control_busy_.load()) return;
  for (Transfer& t : transfers_) libusb_free_transfer(t.transfer);
  transfers_.clear();
  if (control_ != nullptr) libusb_free_transfer(control_);
  control_ = nullptr;
}

void RecordStream::configure(const RecordPlan& plan, const UsbInstrumentConfig& config) {
  halt();
  instrument_.run_on_event_thread([&] {
    if (in_flight_.load() != 0 || control_busy_.load()) {
      // halt() gave up waiting: libusb still owns transfers that point at this stream.
      throw UsbError("usb: the record stream of " + instrument_.description() +
                         " did not stop; cannot reconfigure it",
                     0);
    }
    free_transfers();
    plan_ = plan;
    transfer_count_ = config.transfers_in_flight;
    staging_count_ = config.staging_buffers;
    control_timeout_ms_ = config.control_timeout_ms;
    staging_bytes_ = (plan.chunk_bytes + 4095u) / 4096u * 4096u;
    auto* memory = static_cast<std::uint8_t*>(
        std::aligned_alloc(4096, staging_bytes_ * std::size_t{staging_count_}));
    if (memory == nullptr) throw std::bad_alloc();
    staging_memory_.reset(memory);

    transfers_.resize(transfer_count_);
    for (std::uint32_t i = 0; i < transfer_count_; ++i) {
      transfers_[i] = Transfer{};
      transfers_[i].stream = this;
      transfers_[i].index = i;
      transfers_[i].transfer = libusb_alloc_transfer(0);
      if (transfers_[i].transfer == nullptr) throw std::bad_alloc();
    }
    control_ = libusb_alloc_transfer(0);
    if (control_ == nullptr) throw std::bad_alloc();
    control_buffer_ = std::make_unique<std::uint8_t[]>(LIBUSB_CONTROL_SETUP_SIZE);

    idle_transfers_.clear();
    idle_transfers_.reserve(transfer_count_);
    free_staging_.clear();
    free_staging_.reserve(staging_count_);
    // Everything that can be outstanding at once: a group's parts, plus the next group's
    // parts, which need staging buffers or transfers.
    completions_ = std::make_unique<SpscQueue<Completion>>(plan.parts_per_group() + staging_count_ +
                                                           transfer_count_ + 16);
    released_staging_ = std::make_unique<SpscQueue<std::int32_t>>(staging_count_ + 16);
    phase_ = Phase::stopped;
  });
}

std::uint64_t RecordStream::start() {
  int failure = 0;
  int queued = 0;
  std::uint64_t epoch = 0;
  instrument_.run_on_event_thread([&] {
    Completion stale;
    while (completions_->pop(stale)) {
    }
    std::int32_t id;
    while (released_staging_->pop(id)) {
    }
    free_staging_.clear();
    for (std::int32_t i = static_cast<std::int32_t>(staging_count_) - 1; i >= 0; --i) {
      free_staging_.push_back(i);
    }
    idle_transfers_.clear();
    for (std::uint32_t i = transfer_count_; i > 0; --i) idle_transfers_.push_back(i - 1);
    epoch_ += 1;
    epoch = epoch_;
    acknowledged_epoch_.store(epoch_, std::memory_order_release);
    resync_epoch_.store(epoch_, std::memory_order_release);
    target_epoch_ = epoch_;
    cursor_group_ = 0;
    cursor_part_ = 0;
    published_group_.store(~std::uint64_t{0}, std::memory_order_release);
    published_slot_.store(nullptr, std::memory_order_release);
    lost_.store(false, std::memory_order_release);
    starved_.store(false, std::memory_order_release);
    last_submit_error_.store(0, std::memory_order_relaxed);
    phase_ = Phase::streaming;
    pump();
    queued = in_flight_.load();
    failure = last_submit_error_.load();
    if (phase_ == Phase::lost) failure = LIBUSB_ERROR_NO_DEVICE;
  });
  if (failure != 0) {
    halt();
    std::string what = "usb: queueing " + std::to_string(transfer_count_) +
                       " bulk IN transfers of " + std::to_string(plan_.chunk_bytes) + " bytes on " +
                       instrument_.description() + " failed after " + std::to_string(queued);
    std::string text = describe_usb_failure(what, failure);
    if (failure == LIBUSB_ERROR_NO_MEM) text += "; " + usbfs_memory_advice(bytes_in_flight_limit());
    throw UsbError(text, failure);
  }
  return epoch;
}

void RecordStream::halt() noexcept {
  try {
    instrument_.run_on_event_thread([&] {
      if (phase_ == Phase::stopped) return;
      begin_cancel(Phase::stopped);
    });
  } catch (...) {
    // The event thread is gone; then nothing is being handled and nothing can complete.
  }
  const std::uint64_t deadline = monotonic_ns() + kHaltWaitNs;
  wait_idle(deadline);
  while (control_busy_.load(std::memory_order_acquire) && monotonic_ns() < deadline) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

// --- real-time side ---

void RecordStream::publish_slot(std::uint64_t group, std::uint8_t* slot) noexcept {
  published_slot_.store(slot, std::memory_order_release);
  published_group_.store(group, std::memory_order_release);
  // The event side stopped submitting for want of staging buffers: the slot lets it go on, but
  // it would only notice at its next wake-up (status reports come each ms).
  if (starved_.load(std::memory_order_acquire)) instrument_.wake_event_thread();
}

void RecordStream::release(std::int32_t id) noexcept {
  if (id == kNoStaging) return;
  // Sized for every staging buffer at once, so never full.
  static_cast<void>(released_staging_->push(id));
  if (starved_.load(std::memory_order_acquire)) instrument_.wake_event_thread();
}

bool RecordStream::resync(std::uint64_t epoch, std::uint64_t next_group,
                          std::uint64_t deadline_ns) noexcept {
  resync_group_.store(next_group, std::memory_order_release);
  resync_epoch_.store(epoch, std::memory_order_release);
  instrument_.wake_event_thread();
  for (;;) {
    const std::uint32_t seen = progress_.value();
    if (acknowledged_epoch_.load(std::memory_order_acquire) >= epoch) return true;
    if (!progress_.wait(seen, deadline_ns)) {
      return acknowledged_epoch_.load(std::memory_order_acquire) >= epoch;
    }
  }
}

bool RecordStream::wait_idle(std::uint64_t deadline_ns) noexcept {
  for (;;) {
    const std::uint32_t seen = progress_.value();
    if (in_flight_.load(std::memory_order_acquire) == 0) return true;
    if (!progress_.wait(seen, deadline_ns)) return in_flight_.load() == 0;
  }
}

// --- event side ---

void RecordStream::free_staging(std::int32_t id) noexcept {
  if (id != kNoStaging) free_staging_.push_back(id);
}

void RecordStream::pump() noexcept {
  if (phase_ != Phase::streaming) return;
  std::int32_t released;
  while (released_staging_->pop(released)) free_staging_.push_back(released);
  libusb_device_handle* handle = instrument_.handle();
  while (!idle_transfers_.empty()) {
    const RecordPart part = plan_.part(cursor_part_);
    std::uint8_t* destination = nullptr;
    std::int32_t staging = kNoStaging;
    if (part.kind == PartKind::body &&
        published_group_.load(std::memory_order_acquire) == cursor_group_) {
      destination = published_slot_.load(std::memory_order_acquire) + part.slot_offset;
    } else {
      if (free_staging_.empty()) {
        if (!starved_.exchange(true, std::memory_order_acq_rel)) {
          starvations_.fetch_add(1, std::memory_order_relaxed);
        }
        return;
      }
      staging = free_staging_.back();
      free_staging_.pop_back();
      destination = staging_memory_.get() + static_cast<std::size_t>(staging) * staging_bytes_;
    }
    Transfer& t = transfers_[idle_transfers_.back()];
    libusb_fill_bulk_transfer(t.transfer, handle, protocol::kRecordEndpoint, destination,
                              static_cast<int>(part.length), transfer_done, &t, 0);
    const int r = libusb_submit_transfer(t.transfer);
    if (r != 0) {
      free_staging(staging);
      last_submit_error_.store(r, std::memory_order_relaxed);
      submit_failures_.fetch_add(1, std::memory_order_relaxed);
      if (r == LIBUSB_ERROR_NO_DEVICE) enter_lost();
      return;  // retried at the next housekeeping round
    }
    idle_transfers_.pop_back();
    starved_.store(false, std::memory_order_release);
    t.epoch = epoch_;
    t.group = cursor_group_;
    t.part = static_cast<std::uint32_t>(cursor_part_);
    t.staging = staging;
    in_flight_.fetch_add(1, std::memory_order_acq_rel);
    if (++cursor_part_ == plan_.parts_per_group()) {
      cursor_part_ = 0;
      ++cursor_group_;
    }
  }
}

void RecordStream::transfer_done(libusb_transfer* transfer) {
  auto* t = static_cast<Transfer*>(transfer->user_data);
  t->stream->on_transfer_done(*t);
}

void RecordStream::on_transfer_done(Transfer& t) noexcept {
  idle_transfers_.push_back(t.index);
  const int remaining = in_flight_.fetch_sub(1, std::memory_order_acq_rel) - 1;
  const libusb_transfer_status status = t.transfer->status;

  if (phase_ == Phase::cancelling || phase_ == Phase::lost || t.epoch != epoch_) {
    free_staging(t.staging);
    if (status == LIBUSB_TRANSFER_NO_DEVICE && phase_ != Phase::lost) {
      instrument_.mark_lost();
      lost_.store(true, std::memory_order_release);
      if (phase_ == Phase::cancelling) after_cancel_ = Phase::lost;
    }
    if (remaining == 0) {
      if (phase_ == Phase::cancelling) finish_cancel();
      progress_.notify();
    }
    return;
  }
  if (status == LIBUSB_TRANSFER_NO_DEVICE) {
    free_staging(t.staging);
    enter_lost();
    return;
  }

  Completion c;
  c.epoch = t.epoch;
  c.group = t.group;
  c.part = t.part;
  c.status = kPartCompleted;
  c.actual = static_cast<std::uint32_t>(t.transfer->actual_length);
  const bool complete =
      status == LIBUSB_TRANSFER_COMPLETED && t.transfer->actual_length == t.transfer->length;
  if (complete) {
    c.staging = t.staging;
  } else {
    // A stall, an error, a short record: the stream is out of step with the records. Report
    // the part and submit nothing more until the real-time side asks for a resync.
    c.status = status == LIBUSB_TRANSFER_COMPLETED ? kPartShort : static_cast<std::int32_t>(status);
    free_staging(t.staging);
    phase_ = Phase::halted;
  }
  bool wake = c.staging != kNoStaging || !complete || c.part + 1 == plan_.parts_per_group();
  if (!completions_->push(c)) {
    // Cannot happen with the ring sized in configure(); stop rather than lose a part silently.
    free_staging(c.staging);
    phase_ = Phase::halted;
    wake = true;
  }
  // A body part that landed in the slot needs nothing from the real-time thread but counting:
  // it is not woken for it (every record's header wakes it, and so does the group's last part).
  if (wake) progress_.notify();
  pump();
}

void RecordStream::on_events_handled() noexcept {
  if (phase_ == Phase::stopped) return;
  // The status stream or hotplug saw the instrument go while no record transfer was in flight
  // to tell: the real-time side must not wait for its timeout.
  if (phase_ != Phase::lost && phase_ != Phase::cancelling && instrument_.device_lost()) {
    enter_lost();
    return;
  }
  const std::uint64_t requested = resync_epoch_.load(std::memory_order_acquire);
  if (requested > epoch_ && phase_ != Phase::cancelling && requested > target_epoch_) {
    target_epoch_ = requested;
    target_group_ = resync_group_.load(std::memory_order_acquire);
    begin_cancel(phase_ == Phase::lost ? Phase::lost : Phase::restarting);
    return;
  }
  pump();
}

void RecordStream::begin_cancel(Phase after) noexcept {
  if (phase_ == Phase::lost) after = Phase::lost;
  if (after == Phase::stopped) target_epoch_ = epoch_ + 1;
  after_cancel_ = after;
  phase_ = Phase::cancelling;
  for (Transfer& t : transfers_) libusb_cancel_transfer(t.transfer);  // idle ones: NOT_FOUND
  if (in_flight_.load(std::memory_order_acquire) == 0) finish_cancel();
}

void RecordStream::finish_cancel() noexcept {
  epoch_ = target_epoch_;
  cursor_group_ = target_group_;
  cursor_part_ = 0;
  phase_ = after_cancel_;
  acknowledge();
  if (phase_ == Phase::restarting) {
    // The instrument's FIFO holds a partial record at best: stop it (flushes), reset the
    // endpoint, start again at the next B-scan boundary.
    if (control_busy_.load(std::memory_order_acquire)) {
      restart_pending_ = true;  // the previous sequence's request completes first
    } else {
      control_step_ = 0;
      send_control(static_cast<std::uint8_t>(protocol::Request::acq_stop));
    }
  }
}

void RecordStream::acknowledge() noexcept {
  acknowledged_epoch_.store(epoch_, std::memory_order_release);
  progress_.notify();
}

void RecordStream::enter_lost() noexcept {
  instrument_.mark_lost();
  lost_.store(true, std::memory_order_release);
  phase_ = Phase::lost;
  for (Transfer& t : transfers_) libusb_cancel_transfer(t.transfer);
  progress_.notify();
}

void RecordStream::send_control(std::uint8_t request) noexcept {
  libusb_fill_control_setup(control_buffer_.get(), protocol::kRequestTypeOut, request, 0,
                            protocol::kInterfaceNumber, 0);
  libusb_fill_control_transfer(control_, instrument_.handle(), control_buffer_.get(), control_done,
                               this, control_timeout_ms_);
  const int r = libusb_submit_transfer(control_);
  if (r == 0) {
    control_busy_.store(true, std::memory_order_release);
  } else if (r == LIBUSB_ERROR_NO_DEVICE) {
    enter_lost();
  } else if (r != 0) {
    last_submit_error_.store(r, std::memory_order_relaxed);
    phase_ = Phase::halted;  // the real-time side times out and asks again
  }
}

void RecordStream::control_done(libusb_transfer* transfer) {
  static_cast<RecordStream*>(transfer->user_data)->on_control_done();
}

void RecordStream::on_control_done() noexcept {
  control_busy_.store(false, std::memory_order_release);
  if (restart_pending_ && phase_ == Phase::restarting) {
    restart_pending_ = false;
    control_step_ = 0;
    send_control(static_cast<std::uint8_t>(protocol::Request::acq_stop));
    return;
  }
  restart_pending_ = false;
  if (phase_ != Phase::restarting) return;  // a halt or a later resync overtook it
  const libusb_transfer_status status = control_->status;
  if (status == LIBUSB_TRANSFER_NO_DEVICE) {
    enter_lost();
    return;
  }
  if (status != LIBUSB_TRANSFER_COMPLETED) {
    phase_ = Phase::halted;
    return;
  }
  if (control_step_ == 0) {
    control_step_ = 1;
    libusb_clear_halt(instrument_.handle(), protocol::kRecordEndpoint);
    send_control(static_cast<std::uint8_t>(protocol::Request::acq_start));
    return;
  }
  phase_ = Phase::streaming;
  pump();
}

}  // namespace ioct::hal::usb::detail
